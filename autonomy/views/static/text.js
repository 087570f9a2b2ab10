'use strict';
// A mission's text as the pages edit it (autonomy edit, and a class's student page): CodeMirror 6, served from
// the package (vendor/codemirror/codemirror.js, which sets the global CM). It highlights YAML, completes node
// names and parameters from the mission format's JSON Schema (the one `autonomy schema` writes), marks
// problems at their line and column, and keeps the keys the pages had: Tab writes two spaces (YAML takes no
// tabs), Escape then Tab leaves the editor, Ctrl+Enter runs.

/** What the schema says of the nodes: each node's description, and its parameters (name -> schema). */
function schemaNodes(schema) {
  const nodes = new Map();
  const defs = schema.$defs || {};
  for (const [name, node] of Object.entries(defs)) {
    if (name === 'bare' || name === 'node') continue;
    const params = {};
    const shape = (node.properties || {})[name] || {};
    for (const variant of shape.oneOf || [shape]) Object.assign(params, variant.properties || {});
    nodes.set(name, {description: node.description || '', params, bare: (defs.bare?.enum || []).includes(name)});
  }
  return nodes;
}

function paramDetail(param) {
  const parts = [];
  if (param.enum) parts.push(param.enum.join(' | '));
  else if (param.type) parts.push(param.type);
  if (param.minimum !== undefined || param.exclusiveMinimum !== undefined) {
    parts.push(`from ${param.minimum ?? param.exclusiveMinimum}`);
  }
  if (param.maximum !== undefined) parts.push(`to ${param.maximum}`);
  if (param.default !== undefined) parts.push(`default ${param.default}`);
  return parts.join(', ');
}

/** The key of the mapping a key written at `column` on line `lineNumber` belongs to (null: the file's top). */
function parentKey(doc, lineNumber, column) {
  for (let number = lineNumber - 1; number >= 1; number--) {
    const text = doc.line(number).text;
    const found = /^(\s*(?:-\s+)*)([\w@.-]+)\s*:/.exec(text);
    if (!found) {
      if (/^\s*-\s*$/.test(text) || !text.trim() || /^\s*#/.test(text)) continue;
      const indent = /^\s*/.exec(text)[0].length;
      if (indent < column) return null;
      continue;
    }
    if (found[1].length < column) return found[2];
  }
  return null;
}

/** The completions at the cursor: a node's parameters within it, node names where a node goes, values of a choice. */
function missionCompletions(schemaOf) {
  return async (context) => {
    const word = context.matchBefore(/[\w@.-]*/);
    if (!word || (word.from === word.to && !context.explicit)) return null;
    const schema = await schemaOf();
    if (!schema) return null;
    const nodes = schemaNodes(schema);
    const line = context.state.doc.lineAt(context.pos);
    const before = line.text.slice(0, word.from - line.from);
    const nodeOptions = () => [...nodes].map(([name, node]) => ({
      label: name, type: node.bare ? 'keyword' : 'function', info: node.description,
      apply: node.bare ? name : `${name}: `,
    }));
    const paramOptions = (params) => Object.entries(params).map(([name, param]) => ({
      label: name, type: 'property', detail: paramDetail(param), info: param.description || '', apply: `${name}: `,
    }));
    // a value: the choices of the parameter before it
    const value = /([\w@.-]+)\s*:\s*$/.exec(before);
    if (value) {
      const key = value[1];
      if (key === 'tree') return {from: word.from, options: nodeOptions()};
      for (const node of nodes.values()) {
        const param = node.params[key];
        if (param && param.enum) return {from: word.from, options: param.enum.map((v) => ({label: String(v), type: 'enum'}))};
      }
      return null;
    }
    // a key in a flow mapping, `move: {speed: 2, |`: that node's parameters
    const flow = /([\w@.-]+)\s*:\s*\{[^{}]*$/.exec(before);
    if (flow) return nodes.has(flow[1]) ? {from: word.from, options: paramOptions(nodes.get(flow[1]).params)} : null;
    if (!/^\s*(?:-\s+)*$/.test(before) && !/[[,]\s*$/.test(before)) return null;
    const column = before.length;
    const parent = parentKey(context.state.doc, line.number, column);
    if (parent === null) return {from: word.from, options: paramOptions(schema.properties || {})};
    if (nodes.has(parent) && Object.keys(nodes.get(parent).params).some((p) => p !== 'name' && p !== 'children')) {
      const node = nodes.get(parent);
      // a composite's list holds nodes; a node's mapping holds its parameters
      if (!/^\s*-/.test(before)) return {from: word.from, options: paramOptions(node.params)};
    }
    return {from: word.from, options: nodeOptions()};
  };
}

/**
 * A mission's text editor in `parent`.
 *
 * @param {HTMLElement} parent where it goes
 * @param {object} options `label` (its accessible name), `value`, `placeholder`, `onChange(text)`,
 *     `onRun()` (Ctrl+Enter), `schema()` (a promise of the JSON Schema, asked at the first completion)
 * @return {object} `value` (get and set), `setProblems([{line, column, message}])`, `goTo(line, column)`,
 *     `goToLine(line)`, `focus()`, `cursorLine()`, `completing()`, `view` (CodeMirror's)
 */
function textEditor(parent, options) {
  let schema = null;
  const schemaOf = async () => {
    if (!schema && options.schema) schema = await options.schema().catch(() => null);
    return schema;
  };
  const twoSpaces = (view) => {
    if (view.state.selection.ranges.some((range) => !range.empty)) return CM.indentMore(view);
    view.dispatch(view.state.replaceSelection('  '), {scrollIntoView: true, userEvent: 'input'});
    return true;
  };
  const run = () => {
    if (options.onRun) options.onRun();
    return true;
  };
  let quiet = false; // a value set by the page is no change of the student's
  let problemsShown = 0; // how many problems the text has marked
  const colours = new CM.Compartment(); // the highlighting's colours: high contrast or not (contrast.js's contrastOn)
  // CodeMirror's themes go in a <style> element: the page's policy takes it with the response's nonce alone
  const nonce = document.querySelector('meta[name="style-nonce"]')?.content || '';
  const view = new CM.EditorView({
    parent,
    state: CM.EditorState.create({
      doc: options.value || '',
      extensions: [
        CM.EditorView.cspNonce.of(nonce),
        CM.lineNumbers(),
        CM.highlightActiveLineGutter(),
        CM.highlightSpecialChars(),
        CM.history(),
        CM.drawSelection(),
        CM.indentOnInput(),
        CM.bracketMatching(),
        CM.indentUnit.of('  '),
        CM.EditorState.tabSize.of(2),
        colours.of(CM.syntaxHighlighting(contrastOn() ? TEXT_HIGHLIGHT_CONTRAST : TEXT_HIGHLIGHT)),
        CM.yaml(),
        CM.autocompletion({override: [missionCompletions(schemaOf)], activateOnTyping: true}),
        CM.lintGutter(),
        CM.placeholder(options.placeholder || ''),
        CM.keymap.of([
          {key: 'Mod-Enter', run, preventDefault: true},
          {key: 'Tab', run: twoSpaces, shift: CM.indentLess},
          ...CM.completionKeymap,
          ...CM.historyKeymap,
          ...CM.lintKeymap,
          ...CM.defaultKeymap,
        ]),
        // tabindex: focusable as it is, said so for those who look for it (axe's scrollable-region-focusable)
        CM.EditorView.contentAttributes.of({'aria-label': options.label || 'the mission', spellcheck: 'false',
          autocapitalize: 'off', autocorrect: 'off', tabindex: '0'}),
        CM.EditorView.updateListener.of((update) => {
          if (update.docChanged && !quiet && options.onChange) options.onChange(update.state.doc.toString());
        }),
      ],
    }),
  });
  document.addEventListener('autonomy-contrast', (event) => {
    const style = event.detail ? TEXT_HIGHLIGHT_CONTRAST : TEXT_HIGHLIGHT;
    view.dispatch({effects: colours.reconfigure(CM.syntaxHighlighting(style))});
  });
  const positionOf = (line, column) => {
    const doc = view.state.doc;
    const row = doc.line(Math.max(1, Math.min(line, doc.lines)));
    return row.from + Math.max(0, Math.min(column - 1, row.length));
  };
  return {
    view,
    get value() {
      return view.state.doc.toString();
    },
    set value(text) {
      if (text === view.state.doc.toString()) return;
      quiet = true;
      try {
        view.dispatch({changes: {from: 0, to: view.state.doc.length, insert: text}});
      } finally {
        quiet = false;
      }
    },
    setProblems(problems) {
      // none shown and none to show: nothing to do (a dispatch redraws the gutters, 30 ms on 200 lines)
      if (!problems.length && !problemsShown) return;
      const doc = view.state.doc;
      const marks = problems.filter((p) => p.line).map((p) => {
        const from = positionOf(p.line, p.column || 1);
        const row = doc.lineAt(from);
        const word = /^[^\s:,{}[\]]+/.exec(doc.sliceString(from, row.to));
        const to = word ? from + word[0].length : Math.min(row.to, from + 1);
        return {from, to: Math.max(to, from), severity: 'error', message: p.message};
      });
      view.dispatch(CM.setDiagnostics(view.state, marks));
      problemsShown = marks.length;
    },
    goTo(line, column) {
      const at = positionOf(line, column);
      view.dispatch({selection: {anchor: at}, scrollIntoView: true});
      view.focus();
    },
    /** Puts the cursor at the first word of `line`, and the focus in the text. */
    goToLine(line) {
      const row = view.state.doc.line(Math.max(1, Math.min(line, view.state.doc.lines)));
      this.goTo(row.number, /^\s*(?:-\s+)?/.exec(row.text)[0].length + 1);
    },
    focus() {
      view.focus();
    },
    /** Whether completions are being looked for or offered: "pending", "active", or null. */
    completing() {
      return CM.completionStatus(view.state);
    },
    /** The line the cursor is on (1 is the first). */
    cursorLine() {
      return view.state.doc.lineAt(view.state.selection.main.head).number;
    },
  };
}

/** The text's colours (keys blue, values green): each at least 4.5:1 on white and on the active line (WCAG 1.4.3). */
const TEXT_HIGHLIGHT = CM.HighlightStyle.define([
  {tag: CM.tags.definition(CM.tags.propertyName), color: '#1c4e80'},
  {tag: CM.tags.propertyName, color: '#1c4e80'},
  {tag: [CM.tags.string, CM.tags.special(CM.tags.string)], color: '#8a1c1c'},
  {tag: [CM.tags.content, CM.tags.number], color: '#17632b'},
  {tag: [CM.tags.bool, CM.tags.null, CM.tags.atom, CM.tags.keyword], color: '#6b2490'},
  {tag: [CM.tags.comment, CM.tags.lineComment], color: '#5c636a', fontStyle: 'italic'},
  {tag: CM.tags.invalid, color: '#b00020'},
]);

/** The text's colours in high contrast: light on black, 10:1 and more. */
const TEXT_HIGHLIGHT_CONTRAST = CM.HighlightStyle.define([
  {tag: [CM.tags.definition(CM.tags.propertyName), CM.tags.propertyName], color: '#ffeb3b'},
  {tag: [CM.tags.string, CM.tags.special(CM.tags.string)], color: '#ffccbc'},
  {tag: [CM.tags.content, CM.tags.number], color: '#b9f6ca'},
  {tag: [CM.tags.bool, CM.tags.null, CM.tags.atom, CM.tags.keyword], color: '#e1bee7'},
  {tag: [CM.tags.comment, CM.tags.lineComment], color: '#e0e0e0', fontStyle: 'italic'},
  {tag: CM.tags.invalid, color: '#ffeb3b'},
]);
