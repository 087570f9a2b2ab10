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

  /** The marks' spread: a bar a bin, its count over it, its marks under it. */
  function spread(data) {
    const width = 44, gap = 6, tall = 110, top = 20, under = 40;
    const most = Math.max(1, ...data.bins.map((bin) => bin[2]));
    const said = data.bins.map((bin) => `${bin[2]} from ${overviewNumber(bin[0])} to ${overviewNumber(bin[1])}`);
    const picture = overviewSvg("svg", {
      viewBox: `0 0 ${data.bins.length * (width + gap) + gap} ${top + tall + under}`,
      role: "img",
      "aria-label": `Marks out of ${overviewNumber(data.max_points)}, students in each band: ${said.join("; ")}`,
      class: "spread",
    });
    data.bins.forEach(([from, to, count], k) => {
      const x = gap + k * (width + gap), high = (count / most) * tall;
      picture.append(
        overviewSvg("rect", { x, y: top + tall - high, width, height: Math.max(high, count ? 2 : 0.5), class: "bin" }),
      );
      const shown = overviewSvg("text", { x: x + width / 2, y: top + tall - high - 4, "text-anchor": "middle" });
      shown.textContent = String(count);
      const label = overviewSvg("text", { x: x + width / 2, y: top + tall + 17, "text-anchor": "middle" });
      const last = k === data.bins.length - 1;
      label.textContent = last ? `${overviewNumber(from)}-${overviewNumber(to)}` : overviewNumber(from);
      picture.append(shown, label);
    });
    const axis = overviewSvg("text", { x: gap, y: top + tall + 36 });
    axis.textContent = `marks (out of ${overviewNumber(data.max_points)})`;
    picture.append(axis);
    const figure = overviewElement("figure", undefined, "spread");
    figure.append(overviewElement("figcaption", "The marks"), picture);
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

  /** Each criterion: how many earned it in full, in part, not at all; a bar for the full share. */
  function shares(data) {
    const made = table("Each criterion, across the class", ["criterion", "earned in full", "in part", "not at all"]);
    made.className = "shares";
    for (const criterion of data.criteria) {
      const row = overviewElement("tr");
      const name = overviewElement("th", criterion.title || criterion.label);
      name.scope = "row";
      if (criterion.title) name.append(overviewElement("span", ` ${criterion.label}`, "quiet id"));
      const full = overviewElement("td", undefined, "in-full");
      const share = data.graded ? criterion.full / data.graded : 0;
      const bar = overviewElement("span", undefined, "share-bar");
      const fill = overviewElement("span", undefined, "share-fill");
      fill.style.width = `${(share * 100).toFixed(1)}%`;
      bar.append(fill);
      full.append(bar, overviewElement("span", `${criterion.full} of ${data.graded} (${Math.round(share * 100)}%)`));
      row.append(name, full, overviewElement("td", String(criterion.part), "number"),
        overviewElement("td", String(criterion.none), "number"));
      made.tBodies[0].append(row);
    }
    return made;
  }

  /** The node types that were running when marks were lost, the most points lost first. */
  function nodes(data) {
    const made = table("Where the marks were lost: the node running then", ["node", "students", "points lost", "on"]);
    made.className = "nodes";
    if (!data.nodes.length) {
      const row = overviewElement("tr");
      const none = data.graded ? "no mark was lost while a node was running" : "nothing graded yet";
      const cell = overviewElement("td", none);
      cell.colSpan = 4;
      row.append(cell);
      made.tBodies[0].append(row);
    }
    for (const node of data.nodes) {
      const row = overviewElement("tr");
      const name = overviewElement("th", node.node);
      name.scope = "row";
      const on = node.criteria.map(([label, n]) => `${label} (${n})`).join(", ");
      row.append(name, overviewElement("td", String(node.students), "number"),
        overviewElement("td", overviewNumber(node.points_lost), "number"), overviewElement("td", on));
      made.tBodies[0].append(row);
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
      const marked = shown.outcome === "notgraded" ? "" : ` ${shown.mark}`;
      const words = overviewElement("span", ` ${told.words}`, shown.outcome === "notgraded" ? "" : "unseen");
      mark.append(sign, marked, words);
      holder.append(overviewElement("span", shown.student, "who"), mark,
        overviewElement("span", shown.outcome === "notgraded" ? shown.why || "" : shown.seed, "quiet map-seed"));
      if (holder !== item) holder.append(overviewElement("span", ": open their run", "unseen"));
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
    const full = data.maps.filter((m) => m.outcome === "full").length;
    const zero = data.maps.filter((m) => m.outcome === "none").length;
    const said = [`${students(graded)} graded of ${data.students}`];
    if (graded) said.push(`median ${overviewNumber(data.median)} / ${overviewNumber(data.max_points)}`,
      `${full} with full marks`, `${zero} with none`);
    parts.push(overviewElement("p", `${said.join("; ")}.`, "says"));
    const row = overviewElement("div", undefined, "glance");
    row.append(spread(data), shares(data), nodes(data));
    parts.push(row);
    const whose = data.about ? ` (${data.about})` : "";
    const heading = `Each student's worst seed${whose}: the path coloured by their mark, a crash a cross`;
    parts.push(overviewElement("h3", heading));
    parts.push(maps(data, open));
    root.replaceChildren(...parts);
  }

  globalThis.drawOverview = drawOverview;
})();
