'use strict';
// The editor's page: the mission as blocks and as text, side by side. Every conversion is the
// server's (autonomy.mission.blocks): the page keeps no mapping of its own.

const key = location.hash.slice(1);
const element = (id) => document.getElementById(id);
let workspace = null;
let loading = false;
let blocksTimer = null;
let textTimer = null;

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
  if (mission.ok) {
    load(mission.workspace);
    say(`${mission.file}: the blocks and the text are the same mission.`);
  } else if (mission.problems.length) {
    await toBlocks();
  }
  blocksOnChange(workspace, () => {
    if (loading) return;
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
