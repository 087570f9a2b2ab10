'use strict';
// The editor's page: the mission as blocks and as text, side by side. Every conversion is the
// server's (autonomy.mission.blocks): the page keeps no mapping of its own. The text is what is
// saved: a change of the blocks is written into it, and a change of the text is shown as blocks once
// the text has no problem (until then the blocks wait, and take no change: the text is not lost).

const key = location.hash.slice(1);
const element = (id) => document.getElementById(id);
let workspace = null;
let loading = false;
let blocksTimer = null;
let textTimer = null;
let blocksChanged = false; // the blocks changed since the text was last made of them
let savedText = null; // the text as the file has it

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
  if (workspace) blocksWarn(workspace, where === 'blocks' ? problems : []);
}

function load(state) {
  loading = true;
  try {
    blocksLoad(workspace, state);
  } finally {
    loading = false;
  }
  blocksChanged = false;
}

/** The blocks wait (and take no change) while the text has a problem: what is typed is never overwritten. */
function blocksWait(problem) {
  const note = element('blocks-note');
  note.hidden = !problem;
  note.textContent = problem || '';
  element('blocks').inert = Boolean(problem);
  element('blocks').classList.toggle('waiting', Boolean(problem));
}

/** Writes the blocks as the text; whether they had no problem. */
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
    blocksChanged = false;
    showProblems([], 'blocks');
    say('The text is the blocks.');
  } else {
    showProblems(answer.problems, 'blocks');
    say(`The blocks have ${answer.problems.length} problem(s), each on its block: the text stays as it was.`);
  }
  return answer.ok;
}

/** Shows the text as blocks; a text with problems stays text, and the blocks wait. Whether it had none. */
async function toBlocks() {
  clearTimeout(textTimer);
  const text = element('text').value;
  if (!text.trim()) {
    load(BLOCKS_NEW_MISSION);
    blocksWait('');
    showProblems([], 'text');
    return true;
  }
  const answer = await api('/api/blocks', {text});
  if (answer.ok) {
    load(answer.workspace);
    blocksWait('');
    showProblems([], 'text');
    say('The blocks are the text.');
  } else {
    const first = answer.problems[0];
    blocksWait(first
      ? `The text has a problem at line ${first.line}, column ${first.column}: the blocks wait until it is mended.`
      : 'The text is not a mission yet: the blocks wait.');
    showProblems(answer.problems, 'text');
    say(`The text has ${answer.problems.length} problem(s): it stays text until they are mended.`);
  }
  return answer.ok;
}

async function save() {
  if (blocksChanged && !(await toText())) {
    say('Not saved: the blocks have problems, each on its block. Mend them (or delete the blocks outside the mission).');
    return;
  }
  const text = element('text').value;
  const answer = await api('/api/save', {text});
  if (answer.saved) {
    savedText = text;
    const problems = answer.problems || [];
    say(problems.length ? `Saved ${answer.saved}, with ${problems.length} problem(s).` : `Saved ${answer.saved}.`);
    showProblems(problems, 'text');
  } else {
    say(answer.error || 'Not saved.');
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
  workspace = blocksInject(element('blocks'), mission.palette);
  element('text').value = mission.text;
  savedText = mission.text;
  if (mission.ok) {
    load(mission.workspace);
    say(`${mission.file}: the blocks and the text are the same mission.`);
  } else {
    await toBlocks();
    if (!mission.text.trim()) say(`${mission.file} is new: build it from blocks, or write it as text, then save.`);
  }
  blocksOnChange(workspace, () => {
    if (loading) return;
    blocksChanged = true;
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
  document.addEventListener('keydown', (event) => {
    if (event.key === 's' && (event.ctrlKey || event.metaKey)) {
      event.preventDefault();
      save();
    }
  });
  window.addEventListener('beforeunload', (event) => {
    if (blocksChanged || element('text').value !== savedText) event.preventDefault(); // asks before work is lost
  });
  document.body.dataset.ready = 'yes';
}

start().catch((error) => say(`The editor could not start: ${error.message}`));
