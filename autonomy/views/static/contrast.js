'use strict';
// High contrast, on the pages a student or an author writes missions in (autonomy edit, a class's pages): black,
// white and yellow (7:1 and more, WCAG 1.4.6), blocks black with white words and yellow edges, the text's colours
// light on black. A button with `data-contrast` turns it on and off (aria-pressed says which); with no choice made,
// the system's "more contrast" turns it on. The choice is kept in the browser. The page's editors follow the
// `autonomy-contrast` event (text.js); the blocks follow the page's styles.
const CONTRAST_KEY = 'autonomy-contrast';

/** Whether the pages are in high contrast. */
function contrastOn() {
  return document.documentElement.classList.contains('contrast');
}

function setContrast(on, remember) {
  document.documentElement.classList.toggle('contrast', on);
  for (const button of document.querySelectorAll('[data-contrast]')) button.setAttribute('aria-pressed', String(on));
  if (remember) localStorage.setItem(CONTRAST_KEY, on ? 'on' : 'off');
  document.dispatchEvent(new CustomEvent('autonomy-contrast', {detail: on}));
}

(() => {
  const chosen = localStorage.getItem(CONTRAST_KEY);
  setContrast(chosen === null ? matchMedia('(prefers-contrast: more)').matches : chosen === 'on', false);
  for (const button of document.querySelectorAll('[data-contrast]')) {
    button.addEventListener('click', () => setContrast(!contrastOn(), true));
  }
})();
