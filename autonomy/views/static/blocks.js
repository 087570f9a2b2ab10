'use strict';
// Blockly as the pages use it (autonomy edit, and a class's student page): the blocks' definitions
// and toolbox come from the server (autonomy.mission.blocks), which also does every conversion
// between blocks and text; nothing of the mapping is here. Blockly's styles are served as a file
// (vendor/blockly/blockly.css): the pages' policy takes no inline style.

// In the toolbox's list of blocks, Blockly 13 names each block's places for others ("statement position",
// role figure) though nothing can be put there: a list of options may hold options alone, and a screen
// reader would count those places as items. They are made presentation there (not in the workspace).
function quietFlyoutPlaces(root) {
  for (const place of root.querySelectorAll('.blocklyFlyout .blocklyHighlightedConnectionPath[role="figure"]')) {
    place.setAttribute('role', 'none');
    place.removeAttribute('aria-roledescription');
  }
}

/** The blocks of a mission not written yet: the mission's block, empty. */
const BLOCKS_NEW_MISSION = {
  blocks: {
    languageVersion: 0,
    blocks: [{type: '@mission', x: 20, y: 20, fields: {name: 'my-mission', world: '', tick_hz: 20}}],
  },
};

let blocksDefined = false;

/** Blockly in `element`, with the blocks and toolbox of `palette` ({blocks, toolbox}); its workspace. */
function blocksInject(element, palette) {
  if (!blocksDefined) {
    Blockly.common.defineBlocksWithJsonArray(palette.blocks);
    Blockly.blockRendering.ConstantProvider.prototype.injectCSS_ = () => {};
    blocksDefined = true;
  }
  const workspace = Blockly.inject(element, {
    toolbox: palette.toolbox,
    css: false,
    media: '/vendor/blockly/media/',
    sounds: false,
    renderer: 'thrasos',
    theme: Blockly.Themes.Classic,
    trashcan: false,
    move: {scrollbars: true, drag: true, wheel: true},
  });
  quietFlyoutPlaces(element);
  new MutationObserver(() => quietFlyoutPlaces(element)).observe(element, {
    subtree: true,
    childList: true,
    attributeFilter: ['role'],
  });
  return workspace;
}

// For each workspace, which of its blocks stands for each block id of the state last put in it. A new state is put
// in place of the blocks shown where they differ (compared with the blocks themselves, whoever changed them): a
// number changed in the text changes that field, a node added or taken away makes or disposes that block alone.
// Loading the whole workspace again would take Blockly a second for 200 blocks; it is done only when the stacks
// themselves differ (a named step more or less).
const blocksLoaded = new WeakMap();

/** A block's state as one chain: it, then the blocks under it. */
function blocksChain(state) {
  const chain = [];
  for (let at = state; at; at = at.next && at.next.block) chain.push(at);
  return chain;
}

/** What must be the same for a block to be kept: its type and whatever else its state says, bar what a patch sets
 * in place (its fields, data, comment, whether it is turned off or folded) and what it holds. */
function blocksKind(state) {
  const {id, x, y, fields, data, icons, inputs, next, collapsed, enabled, disabledReasons, ...rest} = state;
  return JSON.stringify(Object.keys(rest).sort().map((key) => [key, rest[key]]));
}

/** Makes `state`'s block in `workspace`, with the blocks it holds (and, `under`, the blocks under it); notes the id
 * each is given in `ids`, by its id in `state` (Blockly gives a new one where the id is taken). */
function blocksMake(workspace, state, ids, under = false) {
  const made = {...state};
  if (!under) delete made.next;
  delete made.x;
  delete made.y;
  const block = Blockly.serialization.blocks.append(made, workspace, {recordUndo: false});
  const note = (states, blocks) => {
    states.forEach((at, i) => {
      ids.set(at.id, blocks[i].id);
      for (const [name, input] of Object.entries(at.inputs || {})) {
        note(blocksChain(input.block), blocksUnder(blocks[i].getInputTargetBlock(name)));
      }
    });
  };
  note(under ? blocksChain(state) : [state], [...(under ? blocksUnder(block) : [block])]);
  return block;
}

/** The chain of blocks from `first`: it, then the blocks under it. */
function blocksUnder(first) {
  const blocks = [];
  for (let at = first; at; at = at.getNextBlock()) blocks.push(at);
  return blocks;
}

/** Puts the states `states` in place of `blocks`: a chain that hangs from `connection`, or (no connection) stacks
 * of their own. The blocks kept, first and last, are changed in place; those between are made again. */
function blocksPatchChain(workspace, connection, blocks, states, ids) {
  const same = (block, state) => blocksKind(blocksLoadedStateOf(block)) === blocksKind(state);
  let head = 0;
  while (head < blocks.length && head < states.length && same(blocks[head], states[head])) head += 1;
  let tail = 0;
  while (tail < blocks.length - head && tail < states.length - head
         && same(blocks[blocks.length - 1 - tail], states[states.length - 1 - tail])) tail += 1;
  for (let i = 0; i < head; i += 1) blocksPatchStack(workspace, blocks[i], states[i], ids, !connection);
  for (let i = 1; i <= tail; i += 1) {
    blocksPatchStack(workspace, blocks[blocks.length - i], states[states.length - i], ids, !connection);
  }
  const gone = blocks.slice(head, blocks.length - tail);
  const coming = states.slice(head, states.length - tail);
  if (!gone.length && !coming.length) return;
  const rest = connection ? blocks[blocks.length - tail] || null : null; // the first block kept after the others
  if (rest) rest.unplug(false);
  for (const block of gone) { // in a chain, the first takes the others under it with it
    if (!block.isDeadOrDying()) block.dispose(false);
  }
  let at = head ? blocks[head - 1].nextConnection : connection;
  for (const state of coming) {
    const block = blocksMake(workspace, state, ids, !connection); // alone: a stack of its own, made whole
    if (!connection) continue;
    at.connect(block.previousConnection || block.outputConnection);
    at = block.nextConnection;
  }
  if (rest) at.connect(rest.previousConnection);
}

/** {@link blocksPatch}, and for a stack of its own (`alone`), the blocks under it too. */
function blocksPatchStack(workspace, block, state, ids, alone) {
  blocksPatch(workspace, block, state, ids);
  if (alone) blocksPatchChain(workspace, block.nextConnection, blocksUnder(block.getNextBlock()), blocksChain(state).slice(1), ids);
}

/** Changes `block` (of the same kind as `state`'s) into `state`'s: its fields, its data, the blocks it holds. */
function blocksPatch(workspace, block, state, ids) {
  ids.set(state.id, block.id);
  const had = blocksLoadedStateOf(block);
  for (const [name, value] of Object.entries(state.fields || {})) {
    if (JSON.stringify(value) !== JSON.stringify((had.fields || {})[name])) block.setFieldValue(value, name);
  }
  block.data = state.data || null;
  // as a whole load makes it: turned on, unfolded unless said, its comment (text, size, shown) as the state has it
  for (const reason of block.getDisabledReasons()) block.setDisabledReason(false, reason);
  if (block.isCollapsed() !== Boolean(state.collapsed)) block.setCollapsed(Boolean(state.collapsed));
  const comment = state.icons && state.icons.comment;
  if (JSON.stringify(comment || null) !== JSON.stringify((had.icons && had.icons.comment) || null)) {
    if (!comment) {
      block.setCommentText(null);
    } else {
      if (!block.getCommentText()) block.setCommentText(comment.text);
      block.getIcon(Blockly.icons.IconType.COMMENT).loadState(comment);
    }
  }
  const names = new Set([...Object.keys(state.inputs || {}), ...block.inputList.map((input) => input.name)]);
  for (const name of names) {
    const input = block.getInput(name);
    if (!input || !input.connection) continue;
    const given = state.inputs && state.inputs[name] ? blocksChain(state.inputs[name].block) : [];
    blocksPatchChain(workspace, input.connection, blocksUnder(input.connection.targetBlock()), given, ids);
  }
}

// What each block showed when a state was last put in place (saved once a load: saving is what a diff costs most).
let blocksShown = new WeakMap();

/** What a block shows, as a state of its own (its fields and look; not what it holds). */
function blocksLoadedStateOf(block) {
  let shown = blocksShown.get(block);
  if (!shown) {
    shown = Blockly.serialization.blocks.save(block, {addInputBlocks: false, addNextBlocks: false, addCoordinates: false});
    blocksShown.set(block, shown);
  }
  return shown;
}

/** Lays the named steps one under another below the mission (where blocks stand is not kept). */
function blocksLayOut(workspace) {
  // cleanUp() would move every block, which takes as long again as a load
  const tops = workspace.getTopBlocks(false);
  const mission = tops.find((block) => block.type === '@mission');
  let y = mission ? mission.getRelativeToSurfaceXY().y + mission.getHeightWidth().height + 40 : 20;
  for (const block of tops) {
    if (block === mission) continue;
    block.moveTo(new Blockly.utils.Coordinate(20, y));
    y += block.getHeightWidth().height + 40;
  }
}

/** Puts `state` (Blockly's JSON of a workspace) in `workspace`, firing no change, one stack under another. */
function blocksLoad(workspace, state) {
  const given = (state.blocks && state.blocks.blocks) || [];
  if (!workspace.getTopBlocks(false).length) { // nothing to keep
    blocksLoadWhole(workspace, state);
    blocksLoaded.set(workspace, {ids: null});
    return;
  }
  const ids = new Map();
  blocksShown = new WeakMap();
  let patched = false;
  Blockly.Events.disable();
  try {
    blocksPatchChain(workspace, null, workspace.getTopBlocks(false), given, ids);
    // the stacks in the state's order, as a whole load has them (and saves them); put so only when they are not
    // (a stack put again is drawn again whole)
    const order = given.map((top) => workspace.getBlockById(ids.get(top.id)));
    if (order.some((block, i) => workspace.getTopBlocks(false)[i] !== block)) {
      for (const block of order) {
        workspace.removeTopBlock(block);
        workspace.addTopBlock(block);
      }
    }
    Blockly.renderManagement.triggerQueuedRenders(workspace);
    blocksLayOut(workspace);
    patched = true;
  } catch (error) { // whatever Blockly would not take in place (a block that fits nowhere): the whole load says it
    console.warn('the blocks are loaded whole:', error);
  } finally {
    Blockly.Events.enable();
  }
  blocksShown = new WeakMap();
  if (patched) {
    blocksLoaded.set(workspace, {ids});
    return;
  }
  blocksLoadWhole(workspace, state);
  blocksLoaded.set(workspace, {ids: null});
}

/** Loads `state` in `workspace` whole: every block made again. */
function blocksLoadWhole(workspace, state) {
  Blockly.Events.disable();
  try {
    workspace.clear();
    Blockly.serialization.workspaces.load(state, workspace);
    blocksLayOut(workspace);
  } finally {
    Blockly.Events.enable();
  }
}

// The blocks each workspace shows a problem on: cleared by id (clearing each of 200 blocks would cost a switch 30 ms).
const blocksWarned = new WeakMap();

/** Shows each problem that names a block (`block`: its id) on that block; clears the others'. */
function blocksWarn(workspace, problems) {
  for (const id of blocksWarned.get(workspace) || []) {
    const block = workspace.getBlockById(id);
    if (block) block.setWarningText(null);
  }
  const warned = new Set();
  for (const problem of problems) {
    const block = problem.block ? workspace.getBlockById(problem.block) : null;
    if (block) {
      block.setWarningText(problem.message);
      warned.add(block.id);
    }
  }
  blocksWarned.set(workspace, warned);
}

/** Calls `changed` when the blocks change (not when a block is only looked at, nor while one is on its way). */
function blocksOnChange(workspace, changed) {
  workspace.addChangeListener((event) => {
    if (!event.isUiEvent && Blockly.Events.isEnabled()) changed();
  });
}

/** Keeps the id of the block last selected (by mouse or keys) in `workspace`; a function that gives it. */
function blocksSelection(workspace) {
  let selected = null;
  workspace.addChangeListener((event) => {
    if (event.type === Blockly.Events.SELECTED && event.newElementId) selected = event.newElementId;
    if (event.type === Blockly.Events.BLOCK_DELETE && event.blockId === selected) selected = null;
  });
  return () => (selected && workspace.getBlockById(selected) ? selected : null);
}

/** Gives the keyboard's focus to the block `id` (shown, scrolled to); whether there is one.
 *
 * Given once what is under way is done: a block disposed by the last load hands its focus on to a neighbour a
 * moment later (Blockly's own), which would take it back. */
function blocksFocus(workspace, id) {
  const last = blocksLoaded.get(workspace);
  const shown = last && last.ids && last.ids.has(id) ? last.ids.get(id) : id; // the block kept for it
  const block = shown ? workspace.getBlockById(shown) : null;
  if (block) setTimeout(() => { if (!block.isDeadOrDying()) Blockly.getFocusManager().focusNode(block); });
  return Boolean(block);
}
