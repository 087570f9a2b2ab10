// The parts of CodeMirror 6 the pages use, bundled by `make vendor` (esbuild) into one file that sets the
// global `CM`: autonomy/views/static/vendor/codemirror/codemirror.js. The pages' own use of it is
// autonomy/views/static/text.js.
export {EditorState, Compartment} from '@codemirror/state';
export {
  EditorView, keymap, lineNumbers, highlightActiveLine, highlightActiveLineGutter, drawSelection,
  highlightSpecialChars, placeholder,
} from '@codemirror/view';
export {
  defaultKeymap, history, historyKeymap, indentLess, indentMore, insertNewlineAndIndent,
} from '@codemirror/commands';
export {
  syntaxHighlighting, defaultHighlightStyle, HighlightStyle, indentOnInput, bracketMatching, indentUnit,
  syntaxTree,
} from '@codemirror/language';
export {tags} from '@lezer/highlight';
export {yaml} from '@codemirror/lang-yaml';
export {autocompletion, completionKeymap, completionStatus} from '@codemirror/autocomplete';
export {setDiagnostics, lintGutter, lintKeymap} from '@codemirror/lint';
