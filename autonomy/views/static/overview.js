// The class at a glance (autonomy.classroom.overview's data), drawn the same on the teacher's desk and in
// the class page of `autonomy grade --html`: the marks' spread, each criterion's share of the class, the
// nodes running when marks were lost, and a small map per student, a click away from their run.
// Everything received is put in the page as text or as numbers: no received markup is inserted as HTML.
"use strict";

// Its names kept to itself (the desk's own script has a `table` too): drawOverview alone is given out.
(() => {
  const OVERVIEW_SVG = "http://www.w3.org/2000/svg";
  //: How each outcome is told, in words and a sign as well as in colour.
  const OUTCOMES = {
    full: { sign: "✓", words: "full marks" },
    part: { sign: "◐", words: "part of the marks" },
    none: { sign: "✗", words: "no marks" },
    notgraded: { sign: "–", words: "not graded" },
  };

  function overviewElement(tag, text, className) {
    const made = document.createElement(tag);
    if (text !== undefined) made.textContent = text;
    if (className) made.className = className;
    return made;
  }

  function overviewSvg(tag, attributes) {
    const made = document.createElementNS(OVERVIEW_SVG, tag);
    for (const [key, value] of Object.entries(attributes || {})) made.setAttribute(key, String(value));
    return made;
  }

  function overviewNumber(value) {
    return String(Math.round(value * 100) / 100);
  }

  function students(n) {
    return `${n} student${n === 1 ? "" : "s"}`;
  }

  /** The marks' spread: a bar a bin, its count over it, the marks at the edges of the bins under it. */
  function spread(data) {
    const figure = overviewElement("figure", undefined, "spread");
    figure.append(overviewElement("figcaption", "The marks"));
    if (!data.graded) {
      figure.append(overviewElement("p", "Nothing graded yet: the marks show here once a run is graded.", "none-yet"));
      return figure;
    }
    const width = 44, gap = 6, tall = 110, top = 20, under = 40, side = 12;  // side: room for the edges' marks
    const most = Math.max(1, ...data.bins.map((bin) => bin[2]));
    const said = data.bins.map((bin) => `${bin[2]} from ${overviewNumber(bin[0])} to ${overviewNumber(bin[1])}`);
    const picture = overviewSvg("svg", {
      viewBox: `${-side} 0 ${data.bins.length * (width + gap) + gap + 2 * side} ${top + tall + under}`,
      role: "img",
      "aria-label": `Marks out of ${overviewNumber(data.max_points)}, students in each band: ${said.join("; ")}`,
      class: "spread",
    });
    const edge = (x, value) => {
      const label = overviewSvg("text", { x, y: top + tall + 17, "text-anchor": "middle", class: "edge" });
      label.textContent = overviewNumber(value);
      picture.append(overviewSvg("line", { x1: x, x2: x, y1: top + tall, y2: top + tall + 4, class: "tick" }), label);
    };
    data.bins.forEach(([from, to, count], k) => {
      const x = gap + k * (width + gap), high = (count / most) * tall;
      picture.append(
        overviewSvg("rect", { x, y: top + tall - high, width, height: Math.max(high, count ? 2 : 0.5), class: "bin" }),
      );
      const shown = overviewSvg("text", { x: x + width / 2, y: top + tall - high - 4, "text-anchor": "middle" });
      shown.textContent = String(count);
      picture.append(shown);
      edge(x - gap / 2, from);
      if (k === data.bins.length - 1) edge(x + width + gap / 2, to);
    });
    const axis = overviewSvg("text", { x: gap, y: top + tall + 36 });
    axis.textContent = `marks (out of ${overviewNumber(data.max_points)}), full marks in the last bar`;
    picture.append(axis);
    figure.append(picture);
    return figure;
  }

  function table(caption, heads) {
    const made = overviewElement("table");
    made.append(overviewElement("caption", caption));
    const head = overviewElement("tr");
    for (const text of heads) {
      const th = overviewElement("th", text);
      th.scope = "col";
      head.append(th);
    }
    made.append(overviewElement("thead"), overviewElement("tbody"));
    made.tHead.append(head);
    return made;
  }

  /** Each criterion: its points, how many earned it in full, in part, not at all; a bar for the full share. */
  function shares(data) {
    const heads = ["criterion", "points", "earned in full", "in part", "not at all"];
    const made = table("Each criterion, across the class", heads);
    made.className = "shares";
    for (const criterion of data.criteria) {
      const row = overviewElement("tr");
      const name = overviewElement("th", criterion.title || criterion.label);
      name.scope = "row";
      if (criterion.title) name.append(overviewElement("span", ` ${criterion.label}`, "quiet id"));
      // a criterion of no points is told to the student, not marked: said so, not shown as a share of the marks
      const points = overviewElement("td", criterion.points ? overviewNumber(criterion.points) : "none (a hint)",
        criterion.points ? "number" : "number quiet");
      if (!criterion.points) row.className = "hint";
      const full = overviewElement("td", undefined, "in-full");
      const share = data.graded ? criterion.full / data.graded : 0;
      const bar = overviewElement("span", undefined, "share-bar");
      const fill = overviewElement("span", undefined, "share-fill");
      fill.style.width = `${(share * 100).toFixed(1)}%`;
      bar.append(fill);
      full.append(bar, overviewElement("span", `${criterion.full} of ${data.graded} (${Math.round(share * 100)}%)`));
      row.append(name, points, full, overviewElement("td", String(criterion.part), "number"),
        overviewElement("td", String(criterion.none), "number"));
      made.tBodies[0].append(row);
    }
    return made;
  }

  function nodeRow(node, name) {
    const row = overviewElement("tr");
    const head = overviewElement("th", name);
    head.scope = "row";
    const on = node.criteria.map(([label, n]) => `${label} (${n})`).join(", ");
    row.append(head, overviewElement("td", String(node.students), "number"),
      overviewElement("td", overviewNumber(node.points_lost), "number"), overviewElement("td", on));
    return row;
  }

  /**
   * The node types that were running when marks were lost, the most points lost first; then the points lost
   * with no node named; then how much of all the points lost the rows hold.
   */
  function nodes(data) {
    const made = table("Where the marks were lost: the node running then", ["node", "students", "points lost", "on"]);
    made.className = "nodes";
    const lost = data.lost || { points: 0, shown: 0, unnamed: { points_lost: 0 } };
    const body = made.tBodies[0];
    for (const node of data.nodes) body.append(nodeRow(node, node.node));
    if (lost.unnamed.points_lost > 0.005) {
      const row = nodeRow(lost.unnamed, "no node named");
      row.className = "unnamed";
      row.cells[3].append(overviewElement("span",
        " (about the whole run, or counting only with another criterion)", "quiet"));
      body.append(row);
    }
    const foot = made.createTFoot().insertRow();
    const said = overviewElement("td");
    said.colSpan = 4;
    foot.append(said);
    if (!data.graded) said.textContent = "Nothing graded yet.";
    else if (lost.points <= 0.005) said.textContent = "No marks were lost.";
    else {
      const held = lost.shown;
      const share = Math.round((held / lost.points) * 100);
      said.textContent = `These rows hold ${overviewNumber(held)} of the ${overviewNumber(lost.points)} points ` +
        `lost across the class (${share}%)` + (held < lost.points - 0.005 ? "; the rest, under other nodes." : ".");
    }
    return made;
  }

  /** A student's worst seed: the world as that seed drew it, the path coloured by their outcome, each collision. */
  function littleMap(world, shown) {
    const [width, height] = world.arena_mm;
    const picture = overviewSvg("svg", { viewBox: `0 0 ${width} ${height}`, "aria-hidden": "true", class: "little" });
    const flipped = overviewSvg("g", { transform: `translate(0,${height}) scale(1,-1)` });
    const shape = ([kind, ...n], className) =>
      kind === "box"
        ? overviewSvg("rect", { x: n[0], y: n[1], width: n[2], height: n[3], class: className })
        : overviewSvg("circle", { cx: n[0], cy: n[1], r: n[2], class: className });
    flipped.append(overviewSvg("rect", { x: 0, y: 0, width, height, class: "arena" }));
    for (const [, ...zone] of world.zones) flipped.append(shape(zone, "zone"));
    for (const obstacle of world.obstacles) flipped.append(shape(obstacle, "obstacle"));
    if (shown.path.length) {
      flipped.append(overviewSvg("polyline", { points: shown.path.map((p) => p.join(",")).join(" "), class: "path" }));
      const [x, y] = shown.path[shown.path.length - 1];
      flipped.append(overviewSvg("circle", { cx: x, cy: y, r: Math.max(width, height) / 60, class: "end" }));
    }
    const dot = Math.max(width, height) / 70;
    for (const [x, y] of shown.beeps || []) flipped.append(overviewSvg("circle", { cx: x, cy: y, r: dot, class: "beep" }));
    const cross = Math.max(width, height) / 40;
    for (const [x, y] of shown.collisions) {
      flipped.append(overviewSvg("path", {
        d: `M${x - cross},${y - cross}L${x + cross},${y + cross}M${x - cross},${y + cross}L${x + cross},${y - cross}`,
        class: "collision",
      }));
    }
    picture.append(flipped);
    return picture;
  }

  /** One map a student, each a link (or, given `open`, a button) to their run. */
  function maps(data, open) {
    const list = overviewElement("ul", undefined, "maps");
    for (const shown of data.maps) {
      const told = OUTCOMES[shown.outcome] || OUTCOMES.notgraded;
      const item = overviewElement("li", undefined, `map ${shown.outcome}`);
      let holder = item;
      if (shown.link && open) {
        holder = overviewElement("button");
        holder.type = "button";
        holder.addEventListener("click", () => open(shown));
      } else if (shown.link) {
        holder = overviewElement("a");
        holder.href = shown.link;
      }
      if (holder !== item) item.append(holder);
      if (shown.world && data.worlds[shown.world]) holder.append(littleMap(data.worlds[shown.world], shown));
      const mark = overviewElement("span", undefined, "mark");
      const sign = overviewElement("span", told.sign);
      sign.setAttribute("aria-hidden", "true");
      const graded = shown.outcome !== "notgraded";
      const words = overviewElement("span", ` ${told.words}`, graded ? "unseen" : "");
      mark.append(sign, graded ? ` ${shown.mark}` : "", words, graded ? ` on ${shown.seed}` : "");
      const who = overviewElement("span", shown.student, "who");
      who.title = shown.student;  // a long name is cut to two lines: whole on hovering, and read out whole
      const under = graded ? `their mark ${shown.total}` : shown.why || "";
      holder.append(who, mark, overviewElement("span", under, "quiet map-seed"));
      if (holder !== item) holder.append(overviewElement("span", `: open their run on ${shown.seed || "it"}`, "unseen"));
      list.append(item);
    }
    return list;
  }

  /**
   * Draws the class at a glance into `root` (its children replaced).
   *
   * @param {HTMLElement} root - Where it goes.
   * @param {object} data - autonomy.classroom.overview.class_overview's.
   * @param {function} [open] - Opens a student's run (the desk's viewer); without it, each map is a link.
   */
  function drawOverview(root, data, open) {
    const parts = [];
    const graded = data.graded;
    const said = [`${students(graded)} graded of ${data.students}`];
    if (graded) said.push(`median ${overviewNumber(data.median)} / ${overviewNumber(data.max_points)}`,
      `${data.full_marks} with full marks`, `${data.no_marks} with none`);
    parts.push(overviewElement("p", `${said.join("; ")}.`, "says"));
    const row = overviewElement("div", undefined, "glance");
    row.append(spread(data), shares(data), nodes(data));
    parts.push(row);
    const whose = data.about ? ` (${data.about})` : "";
    const heading = `Each student's worst seed${whose}: the path coloured by what it earned, a crash a cross, a beep a dot`;
    parts.push(overviewElement("h3", heading));
    parts.push(maps(data, open));
    root.replaceChildren(...parts);
  }

  globalThis.drawOverview = drawOverview;
})();
