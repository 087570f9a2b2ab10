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

/** Puts `state` (Blockly's JSON of a workspace) in `workspace`, firing no change, one stack under another. */
function blocksLoad(workspace, state) {
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
