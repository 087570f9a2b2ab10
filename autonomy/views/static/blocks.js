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
  workspace.addChangeListener((event) => { // a change of the student's: the next load is whole
    const last = blocksLoaded.get(workspace);
    if (last && !event.isUiEvent && Blockly.Events.isEnabled()) last.changed = true;
  });
  new MutationObserver(() => quietFlyoutPlaces(element)).observe(element, {
    subtree: true,
    childList: true,
    attributeFilter: ['role'],
  });
  return workspace;
}

// What each workspace last loaded, and whether its blocks were changed since (by the student): a new state of the
// same blocks (the same ids, types and nesting: a number, a choice, a name changed in the text) only changes those
// fields, where loading the whole workspace again would take Blockly a second for 200 blocks.
const blocksLoaded = new WeakMap();

/** Whether two states of blocks (or of chains of blocks) are the same blocks, nested the same, bar their fields. */
function sameBlocks(a, b) {
  if (!a || !b) return a === b;
  if (a.type !== b.type || a.id !== b.id || Boolean(a.next) !== Boolean(b.next)) return false;
  if (JSON.stringify(a.icons || null) !== JSON.stringify(b.icons || null)) return false;
  const inputsA = Object.keys(a.inputs || {}).sort();
  const inputsB = Object.keys(b.inputs || {}).sort();
  if (inputsA.join() !== inputsB.join()) return false;
  if (!inputsA.every((name) => sameBlocks(a.inputs[name].block, b.inputs[name].block))) return false;
  return !a.next || sameBlocks(a.next.block, b.next.block);
}

/** Sets the fields and data of `b`'s blocks that differ from `a`'s (the same blocks, as sameBlocks says). */
function changeFields(workspace, a, b) {
  if (!a) return;
  const block = workspace.getBlockById(b.id);
  for (const [name, value] of Object.entries(b.fields || {})) {
    if (JSON.stringify(value) !== JSON.stringify((a.fields || {})[name])) block.setFieldValue(value, name);
  }
  if ((a.data || null) !== (b.data || null)) block.data = b.data || null;
  for (const name of Object.keys(b.inputs || {})) changeFields(workspace, a.inputs[name].block, b.inputs[name].block);
  if (b.next) changeFields(workspace, a.next.block, b.next.block);
}

/** Puts `state` (Blockly's JSON of a workspace) in `workspace`, firing no change, one stack under another. */
function blocksLoad(workspace, state) {
  const last = blocksLoaded.get(workspace);
  const tops = (given) => (given.blocks && given.blocks.blocks) || [];
  if (last && !last.changed && tops(last.state).length === tops(state).length
      && tops(last.state).every((top, i) => sameBlocks(top, tops(state)[i]))) {
    Blockly.Events.disable();
    try {
      tops(state).forEach((top, i) => changeFields(workspace, tops(last.state)[i], top));
    } finally {
      Blockly.Events.enable();
    }
    blocksLoaded.set(workspace, {state, changed: false});
    return;
  }
  blocksLoadWhole(workspace, state);
  blocksLoaded.set(workspace, {state, changed: false});
}

/** Loads `state` in `workspace` whole: every block made again. */
function blocksLoadWhole(workspace, state) {
  Blockly.Events.disable();
  try {
    workspace.clear();
    Blockly.serialization.workspaces.load(state, workspace);
    // where blocks stand is not kept: the mission where it was loaded, its named steps one under another below
    // it (cleanUp() would move every block, which takes as long again as the load)
    const tops = workspace.getTopBlocks(false);
    const mission = tops.find((block) => block.type === '@mission');
    let y = mission ? mission.getRelativeToSurfaceXY().y + mission.getHeightWidth().height + 40 : 20;
    for (const block of tops) {
      if (block === mission) continue;
      block.moveTo(new Blockly.utils.Coordinate(20, y));
      y += block.getHeightWidth().height + 40;
    }
  } finally {
    Blockly.Events.enable();
  }
}

/** Shows each problem that names a block (`block`: its id) on that block; clears the others'. */
function blocksWarn(workspace, problems) {
  for (const block of workspace.getAllBlocks(false)) block.setWarningText(null);
  for (const problem of problems) {
    const block = problem.block ? workspace.getBlockById(problem.block) : null;
    if (block) block.setWarningText(problem.message);
  }
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

/** Gives the keyboard's focus to the block `id` (shown, scrolled to); whether there is one. */
function blocksFocus(workspace, id) {
  const block = id ? workspace.getBlockById(id) : null;
  if (block) Blockly.getFocusManager().focusNode(block);
  return Boolean(block);
}
