'use strict';
// The editor's page: the mission as blocks and as text, side by side. Every conversion is the
// server's (autonomy.mission.blocks): the page keeps no mapping of its own.

const key = location.hash.slice(1);
const element = (id) => document.getElementById(id);
let workspace = null;
let loading = false;
let blocksTimer = null;
let textTimer = null;
let warned = [];

async function api(path, body) {
  const options = {headers: {Authorization: `Bearer ${key}`}};
  if (body !== undefined) {
    options.method = 'POST';
    options.headers['Content-Type'] = 'application/json';
    options.body = JSON.stringify(body);
  }
  const answer = await fetch(path, options);
  const type = answer.headers.get('Content-Type') || '';
  if (!type.includes('json')) throw new Error(await answer.text());
  return answer.json();
}

function say(text) {
  element('status').textContent = text;
}

function showProblems(problems, where) {
  const list = element('problems');
  list.replaceChildren();
  for (const problem of problems) {
    const item = document.createElement('li');
    item.textContent = where === 'text'
      ? `line ${problem.line}, column ${problem.column}: ${problem.message}`
      : problem.message;
    list.append(item);
  }
  for (const block of warned) block.setWarningText(null);
  warned = [];
  if (where === 'blocks' && workspace) {
    for (const problem of problems) {
      const block = problem.block ? workspace.getBlockById(problem.block) : null;
      if (block) {
        block.setWarningText(problem.message);
        warned.push(block);
      }
    }
  }
}

function load(state) {
  loading = true;
  try {
    Blockly.Events.disable();
    workspace.clear();
    Blockly.serialization.workspaces.load(state, workspace);
    workspace.cleanUp(); // the mission and its named steps one under the other: where blocks stand is not kept
  } finally {
    Blockly.Events.enable();
    loading = false;
  }
}

async function toText() {
  clearTimeout(blocksTimer);
  if (workspace.isDragging()) { // a block on its way (by mouse or keys) is not yet where it goes
    blocksTimer = setTimeout(toText, 400);
    return false;
  }
  const state = Blockly.serialization.workspaces.save(workspace);
  const answer = await api('/api/text', {workspace: state});
  if (answer.ok) {
    element('text').value = answer.text;
    element('blocks-note').hidden = true;
    showProblems([], 'blocks');
    say('The text is the blocks.');
  } else {
    showProblems(answer.problems, 'blocks');
    say(`The blocks have ${answer.problems.length} problem(s): the text stays as it was.`);
  }
  return answer.ok;
}

async function toBlocks() {
  clearTimeout(textTimer);
  const answer = await api('/api/blocks', {text: element('text').value});
  const note = element('blocks-note');
  if (answer.ok) {
    load(answer.workspace);
    note.hidden = true;
    showProblems([], 'text');
    say('The blocks are the text.');
  } else {
    const first = answer.problems[0];
    note.textContent = first
      ? `The text has a problem at line ${first.line}, column ${first.column}: the blocks show it as it was before.`
      : 'The text is empty.';
    note.hidden = false;
    showProblems(answer.problems, 'text');
    say(`The text has ${answer.problems.length} problem(s): it stays text until they are mended.`);
  }
  return answer.ok;
}

async function save() {
  const answer = await api('/api/save', {text: element('text').value});
  if (answer.saved) {
    const problems = answer.problems || [];
    say(problems.length ? `Saved ${answer.saved}, with ${problems.length} problem(s).` : `Saved ${answer.saved}.`);
    showProblems(problems, 'text');
  } else {
    say(answer.error || 'Not saved.');
  }
}

// In the toolbox's list of blocks, Blockly 13 names each block's places for others ("statement position",
// role figure) though nothing can be put there: a list of options may hold options alone, and a screen
// reader would count those places as items. They are made presentation there (not in the workspace).
function quietFlyoutPlaces(root) {
  for (const place of root.querySelectorAll('.blocklyFlyout .blocklyHighlightedConnectionPath[role="figure"]')) {
    place.setAttribute('role', 'none');
    place.removeAttribute('aria-roledescription');
  }
}

async function start() {
  const mission = await api('/api/mission');
  if (mission.error) {
    say(mission.error);
    return;
  }
  element('file').textContent = mission.file;
  document.title = `${mission.file}: autonomy edit`;
  Blockly.common.defineBlocksWithJsonArray(mission.palette.blocks);
  // The renderer's styles are in blockly.css, served as a file: the page's policy takes no inline style.
  Blockly.blockRendering.ConstantProvider.prototype.injectCSS_ = () => {};
  workspace = Blockly.inject(element('blocks'), {
    toolbox: mission.palette.toolbox,
    css: false,
    media: '/vendor/blockly/media/',
    sounds: false,
    renderer: 'thrasos',
    theme: Blockly.Themes.Classic,
    trashcan: false,
    move: {scrollbars: true, drag: true, wheel: true},
  });
  const blocks = element('blocks');
  quietFlyoutPlaces(blocks);
  new MutationObserver(() => quietFlyoutPlaces(blocks)).observe(blocks, {
    subtree: true,
    childList: true,
    attributeFilter: ['role'],
  });
  element('text').value = mission.text;
  if (mission.ok) {
    load(mission.workspace);
    say(`${mission.file}: the blocks and the text are the same mission.`);
  } else if (mission.problems.length) {
    await toBlocks();
  }
  workspace.addChangeListener((event) => {
    if (loading || event.isUiEvent) return;
    clearTimeout(blocksTimer);
    blocksTimer = setTimeout(toText, 400);
  });
  element('text').addEventListener('input', () => {
    clearTimeout(textTimer);
    textTimer = setTimeout(toBlocks, 800);
  });
  element('to-text').addEventListener('click', toText);
  element('to-blocks').addEventListener('click', toBlocks);
  element('save').addEventListener('click', save);
  document.body.dataset.ready = 'yes';
}

start().catch((error) => say(`The editor could not start: ${error.message}`));
