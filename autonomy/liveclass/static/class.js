// A student's page: sign in with the code on their sheet, write the mission (checked as they type:
// problems at their lines, the tree drawn), run it on the public seeds, hand it in, see the marks.
// Everything the server sends is put in the page as text (textContent), pictures as images: no
// received markup is ever inserted as HTML.
"use strict";

const CODE_KEY = "autonomy-class-code";
const CHECK_AFTER_MS = 300; // a check this long after the last key typed

let code = sessionStorage.getItem(CODE_KEY) || "";
let deadlineS = null;
let handInsOpen = true;
let busy = false; // a run or a hand-in under way
let checkTimer = 0;
let checkedText = null; // the text the problems and the tree shown are of
let queue = Promise.resolve(); // one request under way at a time: the server takes no second one

/** Runs `task` after every request before it has had its answer. */
function inTurn(task) {
  const done = queue.then(task, task);
  queue = done.catch(() => undefined);
  return done;
}

/** A request to the class's API; the answer's status and JSON (or a made-up one when the server is out of reach). */
async function api(method, path, body) {
  const headers = { Authorization: `Bearer ${code}` };
  if (body !== undefined) headers["Content-Type"] = "application/json";
  try {
    const answer = await fetch(path, { method, headers, body: body === undefined ? undefined : JSON.stringify(body) });
    let data = {};
    try {
      data = await answer.json();
    } catch (_) {
      data = { error: `the server answered ${answer.status}` };
    }
    return { status: answer.status, data };
  } catch (_) {
    return { status: 0, data: { error: "the class's server cannot be reached: is it still running?" } };
  }
}

function svgImage(img, svg) {
  img.src = "data:image/svg+xml;charset=utf-8," + encodeURIComponent(svg);
}

function say(text, isError) {
  $("message").textContent = text;
  $("message").className = isError ? "error" : "";
}

// ------------------------------------------------------------------ signing in

let attempt = 0; // the sign-in whose answer counts: an answer to an earlier one is let go

async function signIn(given) {
  const mine = ++attempt;
  const button = $("sign-in-form").querySelector("button");
  button.disabled = true;
  code = given.trim();
  const { status, data } = await api("GET", "/api/me");
  if (mine !== attempt) return;
  if (status !== 200) {
    code = "";
    sessionStorage.removeItem(CODE_KEY);
    $("sign-in").hidden = false;
    $("sign-in-error").textContent = data.error || `the server answered ${status}`;
    // after a wrong code, the server takes another only a moment later: the button says when
    setTimeout(() => {
      if (mine === attempt) button.disabled = false;
    }, 1000 * (data.retry_after_s || 0));
    return;
  }
  button.disabled = false;
  sessionStorage.setItem(CODE_KEY, code);
  show(data);
}

function show(me) {
  const exercise = me.exercise;
  $("sign-in").hidden = true;
  $("desk").hidden = false;
  $("sign-out").hidden = false;
  $("title").textContent = exercise.title;
  document.title = `${exercise.title}: autonomy`;
  $("who").textContent = me.student.name;
  $("exercise-title").textContent = exercise.title;
  $("exercise-text").textContent = exercise.description;
  $("criteria").replaceChildren(
    ...exercise.criteria.map((c) => element("li", `${c.label}: ${number(c.points)} points`)),
  );
  const hidden = exercise.hidden_seeds ? `, and ${exercise.hidden_seeds} hidden seeds when you hand in` : "";
  $("seeds").textContent =
    `${exercise.time_limit_s} s a run. "Run" tries ${exercise.public_seeds} public seeds${hidden}.`;
  svgImage($("world"), exercise.world_svg);
  $("nodes").replaceChildren(
    ...exercise.nodes.flatMap((n) => [element("dt", n.example), element("dd", `${n.doc} (${n.category})`)]),
  );
  deadline(me);
  missionText.value = me.mission;
  $("handins").replaceChildren();
  for (const work of me.works) if (work.kind === "handin" && work.page) addHandIn(work);
  if (me.mission) check();
  if (localStorage.getItem(MODE_KEY) === "blocks") toBlocks();
  $("robot").hidden = !me.robots;
  robotPoints = me.exercise.robot_points || 0;
  $("robot-marks").textContent = robotPoints
    ? `Your teacher marks it, up to ${number(robotPoints)} points, having watched it: your best-marked run counts ` +
      "beside your hand-in (reload the page to see a new mark)."
    : "It earns no marks.";
  $("robot-runs").replaceChildren();
  for (const run of me.robot_runs || []) addRobotRun(run);
  if (me.robots) followRobot();
}

/** The hand-ins' deadline, as the server's last answer says it (the teacher may change it at any time). */
function deadline(answer) {
  if (answer.hand_ins_open === undefined) return;
  handInsOpen = answer.hand_ins_open;
  if (answer.deadline_s !== undefined) deadlineS = answer.deadline_s;
  const at = deadlineS === null ? "" : new Date(deadlineS * 1000).toLocaleString();
  $("deadline").textContent = handInsOpen
    ? deadlineS === null
      ? ""
      : `Hand-ins close at ${at}.`
    : `Hand-ins are closed${at ? ` (since ${at})` : ""}.`;
  $("handin").disabled = !handInsOpen || busy;
}

// ------------------------------------------------------------------ the editor

// The text is CodeMirror's (text.js): YAML highlighted, node names and parameters completed from the exercise's
// schema, each problem marked at its line and column. Tab writes two spaces; Escape then Tab leaves; Ctrl+Enter runs.
const missionText = textEditor($("mission"), {
  label: "your mission file",
  placeholder: "mission: my-mission\ntree:\n  move: {speed: 2, seconds: 1}",
  onChange: () => {
    clearTimeout(checkTimer);
    checkTimer = setTimeout(check, CHECK_AFTER_MS);
  },
  onRun: () => {
    if (!$("run").disabled) send("run");
  },
  schema: async () => (await paletteReady()).schema,
});

function showProblems(problems) {
  missionText.setProblems(problems);
  $("problems").replaceChildren(
    ...problems.map((p) => {
      const item = element("li");
      item.append(element("span", `line ${p.line}, column ${p.column}:`, "where"), p.message);
      item.dataset.line = String(p.line);
      item.tabIndex = 0;
      item.addEventListener("click", () => goTo(p.line, p.column));
      item.addEventListener("keydown", (event) => {
        if (event.key !== "Enter") return;
        event.preventDefault(); // the Enter would go on to the text, a new line at the problem
        goTo(p.line, p.column);
      });
      return item;
    }),
  );
}

function goTo(line, column) {
  missionText.goTo(line, column);
}

function check() {
  clearTimeout(checkTimer);
  checkTimer = 0;
  const text = missionText.value;
  if (!text.trim()) {
    checkedText = text;
    showProblems([]);
    $("tree").hidden = true;
    $("no-tree").hidden = false;
    $("status").textContent = "Write your mission: it is checked as you type.";
    return Promise.resolve();
  }
  return inTurn(async () => {
    if (text !== missionText.value || text === checkedText) return; // typed on since, or checked already
    $("status").textContent = "checking...";
    const { status, data } = await api("POST", "/api/check", { mission: text });
    if (status !== 200) {
      $("status").textContent = data.error || `the check failed (${status})`;
      return;
    }
    checkedText = text;
    deadline(data);
    if (text !== missionText.value) return; // a newer text has its own check on its way
    showProblems(data.problems);
    $("tree").hidden = !data.ok;
    $("no-tree").hidden = data.ok;
    if (data.ok) svgImage($("tree"), data.tree_svg);
    const count = data.problems_in_all || data.problems.length;
    $("status").textContent = data.ok ? "No problem found: your tree is drawn below." : `${count} problem${count > 1 ? "s" : ""}:`;
    $("status").className = data.ok ? "quiet" : "error";
  });
}

// ------------------------------------------------------------------ blocks

// The mission may be written as blocks: the server turns the text into blocks and the blocks into text
// (the text is what is checked, run and handed in); Blockly is loaded the first time blocks are asked for.
const MODE_KEY = "autonomy-class-mode";
const BLOCKS_AFTER_MS = 400; // the text is made this long after the last change of the blocks
let palette = null; // the exercise's blocks and toolbox
let workspace = null;
let selectedBlock = () => null; // the block last selected
let mode = "text";
let blocksTimer = 0;
let loadingBlocks = false;
let cursorLine = null; // where the text's cursor goes when it is shown again

function loadScript(src) {
  return new Promise((resolve, reject) => {
    const script = document.createElement("script");
    script.src = src;
    script.onload = resolve;
    script.onerror = () => reject(new Error(`${src} could not be loaded`));
    document.head.append(script);
  });
}

async function blocklyReady() {
  if (typeof Blockly === "undefined") {
    await loadScript("/vendor/blockly/blockly_compressed.js");
    await loadScript("/vendor/blockly/en.js");
  }
  if (typeof blocksInject === "undefined") await loadScript("/static/blocks.js");
  await paletteReady();
}

/** The exercise's blocks, toolbox and schema, asked of the server once. */
async function paletteReady() {
  if (!palette) {
    const { status, data } = await inTurn(() => api("GET", "/api/palette"));
    if (status !== 200) throw new Error(data.error || `the server answered ${status}`);
    palette = data;
  }
  return palette;
}

function setMode(next) {
  mode = next;
  localStorage.setItem(MODE_KEY, next);
  $("mode-blocks").setAttribute("aria-pressed", String(next === "blocks"));
  $("mode-text").setAttribute("aria-pressed", String(next === "text"));
  $("blocks-panel").hidden = next !== "blocks";
  $("text-panel").hidden = next !== "text";
  $("text-keys").hidden = next !== "text";
}

function showBlockProblems(problems) {
  $("problems").replaceChildren(
    ...problems.map((p) => element("li", p.block ? p.message : `line ${p.line}, column ${p.column}: ${p.message}`)),
  );
}

/** Shows the mission as blocks; a text with problems stays text (they are said). Whether it is blocks now. */
async function toBlocks() {
  try {
    await blocklyReady();
  } catch (error) {
    $("status").textContent = `The blocks could not be loaded: ${error.message}`;
    return false;
  }
  const text = missionText.value;
  let state = BLOCKS_NEW_MISSION;
  let selected = null;
  if (text.trim()) {
    // the cursor's line: its node's block is the one focused among the blocks
    const line = missionText.cursorLine();
    const { status, data } = await inTurn(() => api("POST", `/api/blocks?line=${line}`, { mission: text }));
    if (status !== 200) {
      $("status").textContent = data.error || `the server answered ${status}`;
      return false;
    }
    if (!data.ok) {
      showProblems(data.problems);
      const first = data.problems[0];
      // said where a check's answer, which may come after, does not write over it
      say(`Your text has a problem at line ${first.line}, column ${first.column}: it stays text until it is mended.`, true);
      return false;
    }
    say("", false);
    state = data.workspace;
    selected = data.selected;
  }
  setMode("blocks");
  if (!workspace) {
    workspace = blocksInject($("blocks"), palette);
    selectedBlock = blocksSelection(workspace);
    blocksOnChange(workspace, () => {
      if (loadingBlocks) return;
      clearTimeout(blocksTimer);
      blocksTimer = setTimeout(toText, BLOCKS_AFTER_MS);
    });
  }
  loadingBlocks = true;
  try {
    blocksLoad(workspace, state);
  } finally {
    loadingBlocks = false;
  }
  Blockly.svgResize(workspace);
  blocksFocus(workspace, selected);
  $("status").textContent = "Your mission as blocks: the toolbox on the left has the blocks you may use.";
  $("status").className = "quiet";
  return true;
}

/**
 * Writes the blocks as the mission's text (what is checked, run and handed in). Whether they had no problem.
 * With `keepCursor`, the text's cursor goes to the line of the block last selected.
 */
async function toText(keepCursor) {
  clearTimeout(blocksTimer);
  blocksTimer = 0;
  if (!workspace || mode !== "blocks") return true;
  if (workspace.isDragging()) {
    blocksTimer = setTimeout(toText, BLOCKS_AFTER_MS); // a block on its way is not yet where it goes
    return false;
  }
  const state = Blockly.serialization.workspaces.save(workspace);
  const selected = keepCursor ? selectedBlock() : null;
  const path = selected ? `/api/text?selected=${encodeURIComponent(selected)}` : "/api/text";
  const { status, data } = await inTurn(() => api("POST", path, { workspace: state }));
  if (status !== 200) {
    $("status").textContent = data.error || `the server answered ${status}`;
    return false;
  }
  blocksWarn(workspace, data.ok ? [] : data.problems);
  if (!data.ok) {
    showBlockProblems(data.problems);
    const count = data.problems.length;
    $("status").textContent = `Your blocks have ${count} problem${count > 1 ? "s" : ""}: each is marked on its block.`;
    $("status").className = "error";
    return false;
  }
  missionText.value = data.mission;
  cursorLine = data.line || null;
  await check();
  return true;
}

// ------------------------------------------------------------------ running and handing in

async function send(kind) {
  if (mode === "blocks" && !(await toText())) {
    say("Mend the blocks first: each problem is marked on its block.", true);
    return;
  }
  const text = missionText.value;
  if (!text.trim()) {
    say("Write a mission first.", true);
    return;
  }
  busy = true;
  $("run").disabled = $("handin").disabled = true;
  const what = kind === "handin" ? "grading it on every seed" : "running it on the public seeds";
  say(`${what}...`, false);
  try {
    // made from blocks: its page opens on them, as the student saw it (and so for the teacher)
    const path = `/api/${kind}${mode === "blocks" ? "?as=blocks" : ""}`;
    const { status, data } = await inTurn(() => api("POST", path, { mission: text }));
    deadline(data);
    if (status === 422) {
      showProblems(data.problems);
      say("It has problems: fix them first (they are marked at their lines).", true);
    } else if (status !== 200) {
      say(data.error || `the server answered ${status}`, true);
    } else {
      say(kind === "handin" ? `Handed in: your hand-in ${data.count}, kept.` : "", false);
      showResult(data);
      if (kind === "handin") addHandIn({ ...data, at: new Date().toISOString() });
    }
  } finally {
    busy = false;
    $("run").disabled = false;
    $("handin").disabled = !handInsOpen;
  }
}

function showResult(result) {
  $("result").hidden = false;
  $("marks").hidden = $("outcomes").hidden = $("notes").hidden = false;
  const where = result.kind === "handin" ? `hand-in ${result.count}, on every seed` : "run, on the public seeds";
  $("result-title").textContent = `Your ${where}: ${number(result.total)} / ${number(result.max_points)}`;
  $("marks").tBodies[0].replaceChildren(
    ...result.criteria.map((c) => {
      const row = element("tr");
      row.append(element("td", c.label), element("td", number(c.earned), "number"), element("td", number(c.points), "number"));
      return row;
    }),
  );
  $("outcomes").replaceChildren(
    // the points first: a run that ended by itself with none must not read as a pass
    ...result.seeds.map((s) => element("li", `${s.seed}: ${number(s.earned)} of ${number(result.max_points)} points (the run: ${s.outcome})`)),
  );
  const notes = [...result.problems, ...result.notes, ...(result.page_problem ? [result.page_problem] : [])];
  $("notes").replaceChildren(...notes.map((n) => element("li", n)));
  $("replay").hidden = !result.page;
  if (result.page) $("replay").src = result.page;
  $("result").scrollIntoView({ block: "start" });
}

function addHandIn(work) {
  $("no-handins").hidden = true;
  const at = work.at ? `, ${new Date(work.at).toLocaleString()}` : "";
  const mark = `${number(work.total)} / ${number(work.max_points)}`;
  const item = element("li", `Hand-in ${work.count}${at}: ${mark}`);
  if (work.page) {
    const open = element("button", "show");
    open.type = "button";
    open.addEventListener("click", () => {
      // its page has its marks, seed by seed: the table above is the last grading's, so it is put away
      $("result").hidden = false;
      $("marks").hidden = $("outcomes").hidden = $("notes").hidden = true;
      $("result-title").textContent = `Your hand-in ${work.count}: ${mark}`;
      $("replay").hidden = false;
      $("replay").src = work.page;
      $("result").scrollIntoView({ block: "start" });
    });
    item.append(open);
  }
  $("handins").append(item);
}

// ------------------------------------------------------------------ on a robot

const ROBOT_EVERY_MS = 2000; // how often the page asks after its place in the queue, or its run
let robotTimer = 0;
let robotShown = null; // the last ticket shown: {state, run}
let robotPoints = 0; // the most the teacher may give a run on a robot (0: such runs earn no marks)

function ordinal(n) {
  const tens = n % 100;
  const suffix = tens >= 11 && tens <= 13 ? "th" : { 1: "st", 2: "nd", 3: "rd" }[n % 10] || "th";
  return `${n}${suffix}`;
}

/** Asks after the student's ticket now, then every ROBOT_EVERY_MS while it waits or runs. */
async function followRobot() {
  clearTimeout(robotTimer);
  const { status, data } = await api("GET", "/api/robot");
  if (status === 200) showRobot(data);
  const ticket = status === 200 ? data.ticket : null;
  if (ticket && ticket.state !== "done") robotTimer = setTimeout(followRobot, ROBOT_EVERY_MS);
}

function showRobot(said) {
  const ticket = said.ticket;
  const waiting = Boolean(ticket && ticket.state === "waiting");
  const running = Boolean(ticket && ticket.state === "running");
  $("robot-ask").disabled = waiting || running;
  $("robot-cancel").hidden = !waiting;
  let text = "";
  if (!ticket) {
    const free = said.free === 1 ? "1 is free" : `${said.free} are free`;
    text = `The class has ${said.robots} robot${said.robots === 1 ? "" : "s"}; ${free}.`;
  } else if (waiting) {
    const starts = said.start_by === "teacher" ? "your teacher starts it" : "it starts as soon as a robot is free";
    text = `You are ${ordinal(ticket.place)} in the queue: ${starts}.${ticket.note ? ` (${ticket.note})` : ""}`;
  } else if (running) {
    text = `Your mission is running on robot ${ticket.robot}.`;
  } else {
    text = `Your run on robot ${ticket.robot}: ${ticket.outcome}. ${ticket.summary}`;
  }
  $("robot-state").textContent = text;
  const view = $("robot-view");
  if (running && ticket.view_port) {
    const address = `${location.protocol}//${location.hostname}:${ticket.view_port}/`;
    if (view.src !== address) view.src = address;
    view.hidden = false;
  }
  const ended = ticket && ticket.state === "done" && robotShown && robotShown.state !== "done";
  if (ended && ticket.run !== null) {
    const run = { number: ticket.run, robot: ticket.robot, outcome: ticket.outcome, at: new Date().toISOString(),
      page: ticket.page, emulated_page: ticket.emulated_page, points: ticket.points };
    addRobotRun(run);
    if (run.emulated_page) showRobotRun(run); // the run and the emulator's beside it
  }
  if (!ended) showBeside(null);
  robotShown = ticket;
}

/** The emulated run beside the robot's (null: none). */
function showBeside(page) {
  $("robot-emulated").hidden = $("robot-emulated-note").hidden = !page;
  if (page) $("robot-emulated").src = page;
  else $("robot-emulated").removeAttribute("src");
}

function showRobotRun(run) {
  $("robot-view").hidden = false;
  $("robot-view").src = run.page;
  showBeside(run.emulated_page || null);
}

function addRobotRun(run) {
  $("no-robot-runs").hidden = true;
  const at = run.at ? `, ${new Date(run.at).toLocaleString()}` : "";
  let marked = "";
  if (robotPoints && run.outcome !== "robot lost") {
    marked = run.points === null || run.points === undefined
      ? " (not marked yet)"
      : ` (your teacher's mark: ${number(run.points)} of ${number(robotPoints)})`;
  }
  const item = element("li", `On robot ${run.robot}${at}: ${run.outcome}${marked}`);
  if (run.page) {
    const open = element("button", "replay");
    open.type = "button";
    open.addEventListener("click", () => showRobotRun(run));
    item.append(open);
  }
  $("robot-runs").append(item);
}

async function askRobot() {
  if (mode === "blocks" && !(await toText())) {
    $("robot-state").textContent = "Mend the blocks first: each problem is marked on its block.";
    return;
  }
  $("robot-ask").disabled = true;
  const { status, data } = await inTurn(() => api("POST", "/api/robot", { mission: missionText.value }));
  if (status !== 200) {
    $("robot-ask").disabled = false;
    $("robot-state").textContent = data.error || `the server answered ${status}`;
    return;
  }
  showRobot(data);
  followRobot();
}

// ------------------------------------------------------------------ wiring

$("robot-ask").addEventListener("click", askRobot);
$("robot-cancel").addEventListener("click", async () => {
  const { status, data } = await api("POST", "/api/robot/cancel", {});
  if (status === 200) showRobot(data);
  else $("robot-state").textContent = data.error || `the server answered ${status}`;
});

$("sign-in-form").addEventListener("submit", (event) => {
  event.preventDefault();
  $("sign-in-error").textContent = "";
  signIn($("code").value);
});
$("sign-out").addEventListener("click", () => {
  sessionStorage.removeItem(CODE_KEY);
  location.reload();
});
$("mode-blocks").addEventListener("click", () => {
  if (mode !== "blocks") toBlocks();
});
$("mode-text").addEventListener("click", async () => {
  if (mode === "text") return;
  let written = false;
  try {
    written = await toText(true);
  } catch (error) {
    $("status").textContent = `Your blocks could not be written as text: ${error.message}`;
    return;
  }
  if (!written) {
    // the text is the blocks' last one without problems: what was built since would be lost
    $("status").textContent = "Mend your blocks first (each problem is marked on its block): then switch to text.";
    return;
  }
  setMode("text");
  if (cursorLine) missionText.goToLine(cursorLine); // the selected block's node
});
$("run").addEventListener("click", () => send("run"));
$("handin").addEventListener("click", () => send("handin"));
// A sign-in link (`/#code=CODE`, from links.csv) signs in with no code typed; the code leaves the address at once.
const linked = new URLSearchParams(location.hash.slice(1)).get("code");
if (linked) {
  history.replaceState(null, "", location.pathname + location.search);
  signIn(linked);
} else if (code) signIn(code);
else $("code").focus();
