// What the student's and the teacher's pages share: elements made with text (never markup), and marks.
"use strict";

const $ = (id) => document.getElementById(id);

/** A new element holding `text` as text, with `className`. */
function element(tag, text, className) {
  const made = document.createElement(tag);
  if (text !== undefined) made.textContent = text;
  if (className) made.className = className;
  return made;
}

/** A mark as the pages show it: at most two decimals, "-" for none. */
function number(value) {
  return value === null || value === undefined ? "-" : String(Math.round(value * 100) / 100);
}
