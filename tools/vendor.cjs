// make vendor: the built browser libraries the package ships (Blockly; CodeMirror 6, bundled here into one
// file) and the tests use (axe-core), taken from node_modules (npm ci, from package-lock.json), each file with
// its sha256, its version and its licence in VENDOR.json beside it.
// Blockly's styles are taken out of its script into blockly.css: the pages' policy runs no inline style.
'use strict';
const crypto = require('crypto');
const fs = require('fs');
const path = require('path');

const root = path.resolve(__dirname, '..');
const from = path.join(root, 'node_modules', 'blockly');
const to = path.join(root, 'autonomy', 'views', 'static', 'vendor', 'blockly');
const RENDERER = 'thrasos';
const MEDIA = ['sprites.svg', 'dropdown-arrow.svg', 'delete-icon.svg', 'foldout-icon.svg', 'resize-handle.svg',
  'handopen.cur', 'handclosed.cur', 'handdelete.cur', '1x1.gif'];

function styles() {
  const {JSDOM} = require('jsdom');
  const dom = new JSDOM('<!doctype html><html><head></head><body><div id="b"></div></body></html>');
  global.window = dom.window;
  global.document = dom.window.document;
  const Blockly = require(path.join(from, 'blockly_compressed.js'));
  Blockly.Css.inject(document.getElementById('b'), true, 'media/');
  const sheets = [...document.querySelectorAll('style')].map((style) => style.textContent);
  // The renderer's styles, which Blockly would put in a <style> of its own at inject: one per theme the pages use.
  for (const theme of [Blockly.Themes.Classic]) {
    const renderer = Blockly.blockRendering.init(RENDERER, theme);
    sheets.push(renderer.getConstants().getCSS_(`.${renderer.getClassName()}.${theme.getClassName()}`).join('\n'));
  }
  return sheets.join('\n');
}

fs.rmSync(to, {recursive: true, force: true});
fs.mkdirSync(path.join(to, 'media'), {recursive: true});
fs.copyFileSync(path.join(from, 'blockly_compressed.js'), path.join(to, 'blockly_compressed.js'));
fs.copyFileSync(path.join(from, 'msg', 'en.js'), path.join(to, 'en.js'));
fs.copyFileSync(path.join(from, 'LICENSE'), path.join(to, 'LICENSE'));
for (const name of MEDIA) fs.copyFileSync(path.join(from, 'media', name), path.join(to, 'media', name));
fs.writeFileSync(path.join(to, 'blockly.css'), styles());

function record(library, folder, names, more = {}) {
  const files = {};
  for (const name of names) {
    files[name] = crypto.createHash('sha256').update(fs.readFileSync(path.join(folder, name))).digest('hex');
  }
  const meta = JSON.parse(fs.readFileSync(path.join(root, 'node_modules', library, 'package.json'), 'utf8'));
  const vendor = {name: meta.name, version: meta.version, licence: meta.license, ...more, files};
  fs.writeFileSync(path.join(folder, 'VENDOR.json'), JSON.stringify(vendor, null, 1) + '\n');
  console.log(`vendored ${meta.name} ${meta.version} (${meta.license}) into ${path.relative(root, folder)}`);
}

record('blockly', to, ['blockly_compressed.js', 'en.js', 'blockly.css', 'LICENSE', ...MEDIA.map((m) => `media/${m}`)]);

// axe-core, for the tests alone: the pages' accessibility checked in Chromium, served from here.
const axeFrom = path.join(root, 'node_modules', 'axe-core');
const axeTo = path.join(root, 'tests', 'vendor', 'axe-core');
fs.rmSync(axeTo, {recursive: true, force: true});
fs.mkdirSync(axeTo, {recursive: true});
for (const name of ['axe.min.js', 'LICENSE']) fs.copyFileSync(path.join(axeFrom, name), path.join(axeTo, name));
record('axe-core', axeTo, ['axe.min.js', 'LICENSE']);

// CodeMirror 6: its packages (tools/codemirror.mjs names the parts) bundled by esbuild into one script that sets
// the global CM; every bundled package's version and licence are recorded, their licences' texts in LICENSE.
const cmTo = path.join(root, 'autonomy', 'views', 'static', 'vendor', 'codemirror');
fs.rmSync(cmTo, {recursive: true, force: true});
fs.mkdirSync(cmTo, {recursive: true});
const built = require('esbuild').buildSync({
  entryPoints: [path.join(root, 'tools', 'codemirror.mjs')],
  bundle: true,
  format: 'iife',
  globalName: 'CM',
  minify: true,
  target: 'es2020',
  legalComments: 'none',
  metafile: true,
  outfile: path.join(cmTo, 'codemirror.js'),
});
const bundled = {};
for (const input of Object.keys(built.metafile.inputs)) {
  const found = /node_modules\/((?:@[^/]+\/)?[^/]+)\//.exec(input);
  if (found) bundled[found[1]] = true;
}
const packages = {};
const licences = [];
for (const name of Object.keys(bundled).sort()) {
  const folder = path.join(root, 'node_modules', name);
  const meta = JSON.parse(fs.readFileSync(path.join(folder, 'package.json'), 'utf8'));
  packages[name] = {version: meta.version, licence: meta.license};
  const text = fs.readdirSync(folder).find((file) => /^licen[cs]e/i.test(file));
  if (!text) throw new Error(`${name} has no licence file`);
  licences.push(`${name} ${meta.version} (${meta.license})\n\n${fs.readFileSync(path.join(folder, text), 'utf8').trim()}\n`);
}
fs.writeFileSync(path.join(cmTo, 'LICENSE'), licences.join('\n' + '-'.repeat(72) + '\n\n'));
record('codemirror', cmTo, ['codemirror.js', 'LICENSE'], {bundled: packages});
