'use strict';
// The editor's page: the mission as blocks and as text, side by side. Every conversion is the
// server's (autonomy.mission.blocks): the page keeps no mapping of its own. The text is what is
// saved: a change of the blocks is written into it, and a change of the text is shown as blocks once
// the text has no problem (until then the blocks wait, and take no change: the text is not lost).

const key = location.hash.slice(1);
const element = (id) => document.getElementById(id);
let workspace = null;
let text = null; // the text's editor (text.js)
let selectedBlock = () => null; // the block last selected
let loading = false;
let blocksTimer = null;
let textTimer = null;
let blocksChanged = false; // the blocks changed since the text was last made of them
let conversions = 0; // conversions asked of the server: an answer to one that a later one overtook is let go
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
    if (where === 'text') {
      // a button: it takes the cursor to the problem, in the text
      const go = document.createElement('button');
      go.type = 'button';
      go.className = 'where';
      go.textContent = `line ${problem.line}, column ${problem.column}`;
      go.addEventListener('click', () => text.goTo(problem.line, problem.column));
      item.append(go, `: ${problem.message}`);
    } else {
      item.textContent = problem.message;
    }
    list.append(item);
  }
  if (where === 'text' && text) text.setProblems(problems);
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

/** Writes the blocks as the text; whether they had no problem. `keepCursor`: the text's cursor to the selected block. */
async function toText(keepCursor) {
  clearTimeout(blocksTimer);
  if (workspace.isDragging()) { // a block on its way (by mouse or keys) is not yet where it goes
    blocksTimer = setTimeout(toText, 400);
    return false;
  }
  const state = Blockly.serialization.workspaces.save(workspace);
  const selected = keepCursor === true ? selectedBlock() : null;
  const asked = ++conversions;
  const answer = await api(selected ? `/api/text?selected=${encodeURIComponent(selected)}` : '/api/text', {workspace: state});
  if (asked !== conversions) return false; // the text or the blocks changed again meanwhile: that answer is the one
  if (answer.ok) {
    text.value = answer.text;
    if (answer.line) text.goToLine(answer.line);
    blocksChanged = false;
    showProblems([], 'blocks');
    say('The text is the blocks.');
  } else {
    showProblems(answer.problems, 'blocks');
    say(`The blocks have ${answer.problems.length} problem(s), each on its block: the text stays as it was.`);
  }
  return answer.ok;
}

/** Shows the text as blocks; a text with problems stays text, and the blocks wait. Whether it had none.
 * `keepCursor`: the block of the cursor's node gets the focus. */
async function toBlocks(keepCursor) {
  clearTimeout(textTimer);
  clearTimeout(blocksTimer); // the text is shown as it is now: a change of the blocks before it is the text's to undo
  const asked = ++conversions;
  const written = text.value;
  if (!written.trim()) {
    load(BLOCKS_NEW_MISSION);
    blocksWait('');
    showProblems([], 'text');
    return true;
  }
  const answer = await api(`/api/blocks?line=${text.cursorLine()}`, {text: written});
  if (asked !== conversions) return false;
  if (answer.ok) {
    load(answer.workspace);
    if (keepCursor === true) blocksFocus(workspace, answer.selected);
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
  const saving = text.value;
  const answer = await api('/api/save', {text: saving});
  if (answer.saved) {
    savedText = saving;
    const problems = answer.problems || [];
    say(problems.length ? `Saved ${answer.saved}, with ${problems.length} problem(s).` : `Saved ${answer.saved}.`);
    showProblems(problems, 'text');
  } else {
    say(answer.error || 'Not saved.');
  }
}

/** Runs the mission as the page has it on the emulator, in real time, shown in the live view below. */
async function run() {
  if (blocksChanged && !(await toText())) {
    say('Not run: the blocks have problems, each on its block.');
    return;
  }
  const answer = await api('/api/run', {text: text.value});
  if (!answer.ok) {
    if (answer.problems) {
      showProblems(answer.problems, 'text');
      say(`Not run: the text has ${answer.problems.length} problem(s).`);
    } else {
      say(`Not run: ${answer.error}`);
    }
    return;
  }
  element('run-pane').hidden = false;
  const view = element('view');
  // the view follows each new run by itself; it is at the name this page was opened at, on its own port
  if (!view.src) view.src = `${location.protocol}//${location.hostname}:${answer.view_port}/`;
  element('stop').disabled = false;
  element('run-state').textContent = `Running in the world '${answer.world}' (at most ${answer.max_s} s)...`;
  say('Running on the emulator: the live view is below.');
  watchRun();
}

/** Follows the run until it ends, then says how it ended. */
async function watchRun() {
  const state = await api('/api/run');
  if (state.running) {
    setTimeout(watchRun, 500);
    return;
  }
  element('stop').disabled = true;
  element('run-state').textContent = state.summary || 'The run is over.';
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
  selectedBlock = blocksSelection(workspace);
  text = textEditor(element('text'), {
    label: `the text of ${mission.file}`,
    value: mission.text,
    placeholder: 'mission: my-mission',
    onRun: run,
    schema: async () => mission.palette.schema,
    onChange: () => {
      clearTimeout(textTimer);
      textTimer = setTimeout(toBlocks, 800);
    },
  });
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
  element('to-text').addEventListener('click', () => toText(true));
  element('to-blocks').addEventListener('click', () => toBlocks(true));
  element('save').addEventListener('click', save);
  element('run').addEventListener('click', run);
  element('stop').addEventListener('click', () => api('/api/stop', {stop: true}));
  document.addEventListener('keydown', (event) => {
    if (event.key === 's' && (event.ctrlKey || event.metaKey)) {
      event.preventDefault();
      save();
    }
  });
  window.addEventListener('beforeunload', (event) => {
    if (blocksChanged || text.value !== savedText) event.preventDefault(); // asks before work is lost
  });
  document.body.dataset.ready = 'yes';
}

start().catch((error) => say(`The editor could not start: ${error.message}`));
