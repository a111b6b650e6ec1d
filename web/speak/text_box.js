// The text box: character count, expression-tag buttons, sample sentences, and errors about the
// text marked at the character they name.

import { expressionColor } from '../timeline.js';
import { client, els } from './page.js';

// The expression names the server accepts in tags: configs/viseme/expressions.json (a browser test
// checks that this list matches it).
// checks that this list matches it).
export const EXPRESSIONS = ['joy', 'sadness', 'anger', 'fear', 'disgust', 'surprise', 'neutral', 'smile', 'wink'];

const SAMPLES = [
  ['Launch (中文 + English)', '(joy, 40, 0.5)大家好，欢迎来到 Facecast 的发布会。(surprise, 50, 0.3) Nice to meet you!'],
  ['English', 'Hello there! (smile, 45, 0.4)Today we ship version one, and it speaks.'],
  ['中文', '(sadness, 35, 0.8)今天下雨了，我们明天再见吧。'],
  ['Mood swing', '(anger, 50, 0.3)No, no, no! (anger, 0, 0.6)好吧，算了。(joy, 30, 0.5)Fine.'],
  ['Wink', '(wink, 63, 0.2)你好呀, my friend.'],
];


export function updateCount() {
  const n = [...els.text.value].length;
  const max = client.hello?.limits?.max_text;
  els.textCount.textContent = max ? `${n} / ${max}` : `${n} characters`;
  els.textCount.style.color = max && n > max ? 'var(--bad)' : '';
}

function insertAtCursor(snippet) {
  const ta = els.text;
  const start = ta.selectionStart ?? ta.value.length;
  const end = ta.selectionEnd ?? start;
  ta.setRangeText(snippet, start, end, 'end');
  ta.focus();
  clearTextError();
  updateCount();
}

export function buildTagButtons() {
  els.tagIntensity.addEventListener('input', () => (els.tagIntensityOut.textContent = els.tagIntensity.value));
  for (const name of EXPRESSIONS) {
    const b = document.createElement('button');
    b.type = 'button';
    b.className = 'chip';
    b.dataset.expression = name;
    b.innerHTML = `<span class="sw" style="background:${expressionColor(name)}"></span>${name}`;
    b.title = `Insert (${name}, intensity, ramp seconds) at the cursor`;
    b.addEventListener('click', () => {
      const a = Math.max(0, Math.min(63, Math.round(Number(els.tagIntensity.value) || 0)));
      const t = Math.max(0, Number(els.tagRamp.value) || 0);
      insertAtCursor(`(${name}, ${a}, ${Number(t.toFixed(2))})`);
    });
    els.tagButtons.appendChild(b);
  }
  const reset = document.createElement('button');
  reset.type = 'button';
  reset.className = 'chip';
  reset.dataset.expression = 'reset';
  reset.textContent = 'reset ↺';
  reset.title = 'Insert a tag with intensity 0: the expression returns to neutral';
  reset.addEventListener('click', () => insertAtCursor(`(neutral, 0, ${Number((Number(els.tagRamp.value) || 0.5).toFixed(2))})`));
  els.tagButtons.appendChild(reset);
  for (const [label, text] of SAMPLES) {
    const o = document.createElement('option');
    o.value = text;
    o.textContent = label;
    els.samples.appendChild(o);
  }
  els.samples.addEventListener('change', () => {
    if (!els.samples.value) return;
    els.text.value = els.samples.value;
    els.samples.value = '';
    clearTextError();
    updateCount();
  });
}

export function clearTextError() {
  els.textError.classList.add('hidden');
  els.text.classList.remove('has-error');
}

/** Shows an error about the text; "offset N" in the message marks that character (code points). */
export function showTextError(message, text) {
  const m = /\b(?:offset|character) (\d+)/.exec(message);
  els.textError.replaceChildren();
  const head = document.createElement('div');
  head.textContent = message;
  els.textError.appendChild(head);
  if (m && text !== undefined) {
    const chars = [...text];
    let at = Math.min(Number(m[1]), chars.length);
    // Mark the whole tag when the offset points into one: back to its '(' and on to its ')'.
    let end = at + 1;
    for (let i = at; i >= 0 && at - i < 48; i--) {
      if (chars[i] === ')' || chars[i] === '）') break;
      if (chars[i] === '(' || chars[i] === '（') {
        at = i;
        end = i + 1;
        while (end < chars.length && end - i < 64 && chars[end - 1] !== ')' && chars[end - 1] !== '）') end++;
        break;
      }
    }
    const from = Math.max(0, at - 24);
    const to = Math.min(chars.length, end + 24);
    const snip = document.createElement('span');
    snip.className = 'snippet';
    snip.append((from > 0 ? '…' : '') + chars.slice(from, at).join(''));
    const mark = document.createElement('mark');
    mark.textContent = chars.slice(at, end).join('') || ' ';
    snip.append(mark, chars.slice(end, to).join('') + (to < chars.length ? '…' : ''));
    els.textError.appendChild(snip);
    // Select the spot in the text box too (UTF-16 indices).
    const u16 = chars.slice(0, at).join('').length;
    const u16end = chars.slice(0, end).join('').length;
    if (els.text.value === text) els.text.setSelectionRange(u16, u16end);
  }
  els.textError.classList.remove('hidden');
  els.text.classList.add('has-error');
}
