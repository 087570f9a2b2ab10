// The teacher's page: the class table, kept live (each change is answered to a waiting request), any
// student's latest run replayed, the projector view, the deadline, the exports. The token comes in
// the address's fragment (never sent to the server in the address), is kept for the tab, and taken
// out of the address bar before anything is shown: a projected page shows no token.
// Everything the server sends is put in the page as text: no received markup is inserted as HTML.
"use strict";

const TOKEN_KEY = "autonomy-class-teacher";

let token = location.hash.slice(1) || sessionStorage.getItem(TOKEN_KEY) || "";
if (location.hash) history.replaceState(null, "", location.pathname);
let version = -1;
let table = null;
let shown = null; // the student whose run the viewer shows: {name, page}

function count(n, what) {
  return `${n} ${what}${n === 1 ? "" : "s"}`;
}

function when(text) {
  return text ? new Date(text).toLocaleTimeString() : "";
}

async function api(method, path, body) {
  const headers = { Authorization: `Bearer ${token}` };
  if (body !== undefined) headers["Content-Type"] = "application/json";
  const answer = await fetch(path, { method, headers, body: body === undefined ? undefined : JSON.stringify(body) });
  return answer;
}

function refused(why) {
  $("desk").hidden = true;
  $("board").hidden = true;
  $("no-token").hidden = false;
  $("token-why").textContent = why;
  $("live").textContent = "not signed in";
}

// ------------------------------------------------------------------ the class, live

async function follow() {
  for (;;) {
    let answer;
    try {
      answer = await api("GET", version < 0 ? "/api/class" : `/api/class?after=${version}`);
    } catch (_) {
      $("live").textContent = "the server cannot be reached: trying again";
      await new Promise((resolve) => setTimeout(resolve, 2000));
      continue;
    }
    if (answer.status === 401) {
      sessionStorage.removeItem(TOKEN_KEY);
      refused("This token is not the class's: the server makes a new one each time it starts.");
      return;
    }
    if (answer.status !== 200) {
      $("live").textContent = `the server answered ${answer.status}: trying again`;
      await new Promise((resolve) => setTimeout(resolve, 2000));
      continue;
    }
    sessionStorage.setItem(TOKEN_KEY, token);
    const data = await answer.json();
    $("live").textContent = "live";
    if (data.version !== version) {
      const before = table;
      version = data.version;
      table = data;
      draw(before);
      drawRobots(data.robots);
      glance();
      drawLms();
    }
  }
}

// ------------------------------------------------------------------ the class at a glance

/**
 * `ask` made to run one at a time: asked while it runs, it runs once more when it ends (the class changed
 * meanwhile), never twice at once. A failure is the class's own request's to say (the server cannot be reached).
 */
function oneAtATime(ask) {
  let asking = false;
  let again = false;
  const run = async () => {
    if (asking) {
      again = true;
      return;
    }
    asking = true;
    try {
      await ask();
    } catch (_) {
      // the class's own request says when the server cannot be reached
    } finally {
      asking = false;
    }
    if (again) {
      again = false;
      run();
    }
  };
  return run;
}

const glance = oneAtATime(async () => {
  const answer = await api("GET", "/api/overview");
  if (answer.status === 200) {
    const data = await answer.json();
    drawOverview($("overview"), data, (shown) => view(shown.student, shown.link, `latest run, ${shown.seed}`));
  }
});

function draw(before) {
  $("no-token").hidden = true;
  if ($("board").hidden) $("desk").hidden = false;
  $("title").textContent = table.title;
  document.title = `${table.title}: the teacher's desk`;
  const students = table.students;
  const signedIn = students.filter((s) => s.signed_in).length;
  const handedIn = students.filter((s) => s.handins > 0).length;
  $("counts").textContent = `${students.length} students, ${signedIn} signed in, ${handedIn} handed in.`;
  const closed = table.deadline_s !== null && table.now_s >= table.deadline_s;
  $("deadline-state").textContent =
    table.deadline_s === null
      ? "Hand-ins are open."
      : `Hand-ins ${closed ? "closed" : "close"} at ${new Date(table.deadline_s * 1000).toLocaleString()}.`;
  const old = new Map((before ? before.students : []).map((s) => [s.id, s]));
  $("class-table").tBodies[0].replaceChildren(...students.map((s) => row(s, old.get(s.id))));
  drawBoard();
}

function row(student, before) {
  const tr = element("tr");
  tr.dataset.student = student.id;
  let mark = student.handins ? `${number(student.total)} / ${number(student.max_points)}` : "";
  if (table.robot_points && student.robot_points !== null) {
    mark += `${mark ? " + " : ""}${number(student.robot_points)} / ${number(table.robot_points)} on a robot`;
  }
  tr.append(
    element("td", student.name),
    element("td", student.id),
    element("td", when(student.signed_in)),
    element("td", String(student.runs), "number"),
    element("td", String(student.handins), "number"),
    element("td", mark, "number mark"),
    element("td", student.last_problem, "problem"),
  );
  tr.cells[6].title = student.last_problem;
  const actions = element("td");
  if (student.latest_page) actions.append(button("Replay", () => view(student.name, student.latest_page, "latest run")));
  if (student.handin_page) actions.append(button("Hand-in", () => view(student.name, student.handin_page, "hand-in")));
  tr.append(actions);
  if (before && before.last_work !== student.last_work) tr.className = "fresh";
  return tr;
}

function button(text, action) {
  const made = element("button", text);
  made.type = "button";
  made.addEventListener("click", action);
  return made;
}

function view(name, page, what) {
  shown = { name, page, what };
  $("viewer").hidden = false;
  $("viewer-title").textContent = `${name}: ${what}`;
  $("viewer-frame").src = page;
  $("viewer").scrollIntoView({ block: "start" });
}

// ------------------------------------------------------------------ the projector

function drawBoard() {
  if (!table) return;
  $("board-title").textContent = table.title;
  $("board-cards").replaceChildren(
    ...table.students.map((s) => {
      const card = element("div", undefined, "student");
      const share = s.handins && s.max_points ? Math.max(0, Math.min(1, s.total / s.max_points)) : 0;
      const bar = element("div", undefined, "bar-out");
      const fill = element("div", undefined, "bar-in");
      fill.style.width = `${(share * 100).toFixed(1)}%`;
      bar.append(fill);
      card.append(
        element("div", s.name, "name"),
        element("div", s.handins ? `${number(s.total)} / ${number(s.max_points)}` : "-", "mark"),
        bar,
        element("div", `${count(s.runs, "run")}, ${count(s.handins, "hand-in")}`, "counts"),
      );
      return card;
    }),
  );
}

function projector(on, run) {
  $("board").hidden = !on;
  $("desk").hidden = on;
  $("projector").textContent = on ? "Back to the desk" : "Projector view";
  $("board-cards").hidden = Boolean(run);
  $("board-run").hidden = !run;
  // a run on a robot is its live view's page (the server's own, not a student's): framed as it is
  const live = Boolean(run && run.live);
  $("board-frame").hidden = live;
  $("board-live").hidden = !live;
  if (run) {
    $("board-run-title").textContent = `${run.name}: ${run.what}`;
    $(live ? "board-live" : "board-frame").src = run.page;
  }
  if (!run || live) $("board-frame").removeAttribute("src");
  if (!live) $("board-live").removeAttribute("src");
}

// ------------------------------------------------------------------ the robots

function drawRobots(robots) {
  $("robots").hidden = !robots;
  if (!robots) return;
  $("robots-how").textContent =
    robots.start_by === "teacher"
      ? "Set a robot at the start, then press its Start: the first in the queue runs on it."
      : "A run starts as soon as a robot is free (the exercise says so): Stop ends one.";
  $("robots-table").tBodies[0].replaceChildren(
    ...robots.robots.map((r) => {
      const row = element("tr");
      const state = r.state === "lost" ? `lost: ${r.why}` : r.state;
      const run = r.student ? `${r.student}, ${Math.round(r.running_s)} s` : "";
      const actions = element("td");
      const start = element("button", `Start on ${r.name}`);
      start.type = "button";
      start.disabled = r.state !== "free" || !robots.queue.length;
      start.addEventListener("click", () => robotAction("start", r.name));
      const stop = element("button", `Stop ${r.name}`);
      stop.type = "button";
      stop.disabled = r.state !== "running";
      stop.addEventListener("click", () => robotAction("stop", r.name));
      actions.append(start, " ", stop);
      if (r.state === "running" && r.view_port) {
        const show = element("button", "Show on the projector");
        show.type = "button";
        const page = `${location.protocol}//${location.hostname}:${r.view_port}/`;
        show.addEventListener("click", () => projector(true, { name: r.student, what: `on robot ${r.name}`, page, live: true }));
        actions.append(" ", show);
      }
      row.append(element("td", r.name), element("td", state), element("td", run), actions);
      return row;
    }),
  );
  $("queue-empty").hidden = robots.queue.length > 0;
  $("queue").replaceChildren(
    ...robots.queue.map((t) => element("li", `${t.name} (${t.student}), waiting ${Math.round(t.waiting_s)} s`)),
  );
  drawRobotRuns(robots);
}

let runsDrawn = ""; // the runs as last drawn: drawn again only once they change

/** The class's last runs on robots, each replayed from here, and marked here when the exercise gives them points. */
function drawRobotRuns(robots) {
  const most = robots.robot_points;
  const drawn = JSON.stringify([most, robots.runs]);
  if (drawn === runsDrawn) return;
  runsDrawn = drawn;
  $("robot-marks-how").textContent = most
    ? `A run on a robot is worth up to ${number(most)} points: mark each once you have watched it. ` +
      "A student's best-marked run counts beside their hand-in, in the gradebook's on_robot column."
    : "Runs on robots count for no marks: the exercise gives them none (robot_points: N gives them some).";
  $("robot-runs-empty").hidden = robots.runs.length > 0;
  $("robot-runs-table").hidden = !robots.runs.length;
  // what the teacher was typing, and where, kept through the drawing (a robot's state changes as they type)
  const typed = new Map(
    [...document.querySelectorAll("#robot-runs-table input")]
      .filter((i) => i.dataset.typed) // typed in and not saved: a box nobody touched shows the mark as it is now
      .map((i) => [i.dataset.run, i.value]),
  );
  const focused = document.activeElement && document.activeElement.closest("#robot-runs-table") ? document.activeElement.id : "";
  $("robot-runs-table").tBodies[0].replaceChildren(
    ...robots.runs.map((r) => {
      const row = element("tr");
      const mark = element("td", r.points === null ? "not marked" : `${number(r.points)} / ${number(most)}`, "number");
      const actions = element("td");
      if (r.page) actions.append(button(`Replay run ${r.number}`, () => view(r.name, r.page, `run ${r.number} on robot ${r.robot}`)));
      if (most && r.outcome !== "robot lost") {
        const input = element("input");
        input.type = "number";
        input.min = "0";
        input.max = String(most);
        input.step = "any";
        input.id = `robot-mark-${r.number}`;
        input.dataset.run = String(r.number);
        input.value = typed.has(input.dataset.run) ? typed.get(input.dataset.run) : r.points === null ? "" : String(r.points);
        if (typed.has(input.dataset.run)) input.dataset.typed = "yes";
        input.addEventListener("input", () => {
          input.dataset.typed = "yes";
        });
        input.setAttribute("aria-label", `Mark of run ${r.number}, 0 to ${number(most)}`);
        input.className = "points";
        const save = button(`Save mark of run ${r.number}`, () => markRun(r.number, input));
        save.id = `robot-mark-save-${r.number}`;
        input.addEventListener("keydown", (event) => {
          if (event.key === "Enter") markRun(r.number, input);
        });
        actions.append(" ", input, " ", save);
      }
      row.append(element("td", String(r.number), "number"), element("td", `${r.name} (${r.student})`),
        element("td", r.robot), element("td", r.outcome), mark, actions);
      return row;
    }),
  );
  if (focused && $(focused)) $(focused).focus();
}

async function markRun(number, input) {
  // a box of numbers holding what is not one reads as empty: that is no mark taken back, but a mistake said
  const value = input.value.trim();
  const points = value === "" ? null : Number(value);
  if (input.validity.badInput || (points !== null && !Number.isFinite(points))) {
    $("robots-message").textContent = `run ${number}: a mark is a number, such as 3.5 (empty takes the mark back)`;
    return;
  }
  await robotAction("mark", null, { run: number, points });
}

async function robotAction(action, name, body) {
  const answer = await api("POST", `/api/robots/${action}`, body || { robot: name });
  const done = answer.status === 200;
  if (done) {
    $("robots-message").textContent = action === "mark" ? `Run ${body.run}: ${body.points === null ? "mark taken back" : "mark saved"}.` : "";
    const box = action === "mark" ? $(`robot-mark-${body.run}`) : null;
    if (box) delete box.dataset.typed; // saved: the box shows the mark as kept from now on
    drawRobots(Object.assign({}, table.robots, await answer.json()));
  } else {
    let why = `the server answered ${answer.status}`;
    try {
      why = (await answer.json()).error || why;
    } catch (_) {
      // not JSON: said by its status
    }
    $("robots-message").textContent = why;
  }
  return done;
}

// ------------------------------------------------------------------ the school's LMS

/** What the LMS was told and what waits: its course, its roster, the marks sent to its gradebook. */
const drawLms = oneAtATime(async () => {
  const answer = await api("GET", "/api/lms");
  if (answer.status !== 200) return;
  const lms = await answer.json();
  $("lms").hidden = !lms.lms;
  if (!lms.lms) return;
  $("lms-course").textContent = lms.course
    ? `${lms.lms}: the class is course ${lms.course.title || lms.course.id}'s.` +
      (lms.instructors.length ? ` Its instructors: ${lms.instructors.join(", ")}.` : "")
    : `${lms.lms}: the class is tied to no course yet. Open its link in your course once: it is tied to that course.`;
  const roster = lms.roster;
  $("lms-roster").textContent = !lms.services
    ? "The roster and the gradebook are not used: the LMS's token URL is not given (autonomy class lti-config --token-url)."
    : roster
      ? `The roster was read at ${new Date(roster.read * 1000).toLocaleTimeString()}: ${count(roster.learners, "student")}, ` +
        `${count(roster.instructors, "instructor")}` +
        (roster.left ? `, ${roster.left} who left the course (taken off the class table, their work kept)` : "") +
        (roster.clashes.length ? `; not taken, their id being another LMS person's: ${roster.clashes.join(", ")}` : "") + "."
      : "The roster has not been read yet.";
  $("lms-roster-read").hidden = !lms.services;
  const scores = lms.scores;
  $("lms-scores").textContent =
    `${scores.sent} sent, ${scores.waiting} waiting` + (scores.refused ? `, ${scores.refused} refused by the LMS` : "") + ".";
  $("lms-again").hidden = !scores.refused;
  $("lms-problem").textContent = lms.problem;
  $("lms-problem").className = lms.problem ? "error" : "quiet";
  $("lms-table").hidden = !scores.last.length;
  $("lms-table").tBodies[0].replaceChildren(
    ...scores.last.map((s) => {
      const state = s.refused ? `refused: ${s.refused}` : s.sent ? `sent at ${when(s.sent)}` : "waiting";
      const tr = element("tr");
      tr.append(
        element("td", `${s.name} (${s.id})`),
        element("td", `${number(s.given)} / ${number(s.maximum)}`),
        element("td", when(s.marked)),
        element("td", state),
      );
      return tr;
    }),
  );
});

async function sendAgain() {
  const answer = await api("POST", "/api/lms/again");
  const data = await answer.json();
  $("lms-problem").textContent = answer.status === 200 ? `${count(data.again, "refused mark")} sent again.` : data.error;
  $("lms-problem").className = answer.status === 200 ? "quiet" : "error";
}

async function readRoster() {
  const answer = await api("POST", "/api/lms/roster");
  const data = await answer.json();
  $("lms-problem").textContent = answer.status === 202 ? "Reading the roster..." : data.error;
  $("lms-problem").className = answer.status === 202 ? "quiet" : "error";
}

// ------------------------------------------------------------------ the deadline and the exports

function deskSays(text, isError) {
  $("desk-message").textContent = text;
  $("desk-message").className = isError ? "error" : "quiet";
}

async function setDeadline(deadlineS) {
  const answer = await api("POST", "/api/deadline", { deadline_s: deadlineS });
  const data = await answer.json();
  deskSays(answer.status === 200 ? "" : data.error, answer.status !== 200);
}

async function download(file) {
  deskSays(`making ${file}...`, false);
  const answer = await api("GET", `/api/export/${file}`);
  if (answer.status !== 200) {
    let why = `the server answered ${answer.status}`;
    try {
      why = (await answer.json()).error || why;
    } catch (_) {
      // not JSON: said by its status
    }
    deskSays(why, true);
    return;
  }
  const link = element("a");
  link.href = URL.createObjectURL(await answer.blob());
  link.download = `${table ? table.exercise : "class"}-${file}`;
  document.body.append(link);
  link.click();
  link.remove();
  deskSays(`${file}: downloaded.`, false);
}

$("projector").addEventListener("click", () => projector($("board").hidden, null));
$("viewer-project").addEventListener("click", () => projector(true, shown));
$("viewer-close").addEventListener("click", () => {
  $("viewer").hidden = true;
  $("viewer-frame").removeAttribute("src");
});
$("deadline-set").addEventListener("click", () => {
  const at = $("deadline-at").value;
  if (!at) return deskSays("Choose a date and time first.", true);
  setDeadline(new Date(at).getTime() / 1000);
});
$("close-now").addEventListener("click", () => setDeadline("now")); // the server's clock, not this one's
$("reopen").addEventListener("click", () => setDeadline(null));
$("lms-roster-read").addEventListener("click", readRoster);
$("lms-again").addEventListener("click", sendAgain);
for (const id of ["export-csv", "export-gradescope", "export-feedback"]) {
  $(id).addEventListener("click", () => download($(id).dataset.file));
}
document.addEventListener("keydown", (event) => {
  if (event.key === "Escape" && !$("board").hidden) projector(false, null);
});
if (token) follow();
else refused("This page needs the teacher's token.");
