// Messages to the person: errors, warnings and notes in the corner, each dismissable; keyed alerts
// (e.g. the connection state) replace each other instead of piling up.

export const alerts = [];
let box = null;

function container() {
  if (!box) box = document.getElementById('alerts');
  return box;
}

/**
 * Shows {level: 'error'|'warn'|'info', code, message, key?, sticky?, timeout?}. Errors and warnings
 * stay 12 s unless sticky; info notes 4 s (or `timeout` ms).
 */
export function showAlert(a) {
  const entry = { level: 'error', ...a };
  if (entry.key) dismissAlert(entry.key);
  // The same message twice in a row only refreshes the first one.
  const same = alerts.find((x) => x.message === entry.message && x.code === entry.code);
  if (same) {
    clearTimeout(same.timer);
    arm(same, entry);
    return same;
  }
  const el = document.createElement('div');
  el.className = `alert ${entry.level === 'error' ? '' : entry.level}`.trim();
  el.setAttribute('role', entry.level === 'error' ? 'alert' : 'status');
  el.dataset.code = entry.code || '';
  const msg = document.createElement('div');
  msg.className = 'msg';
  if (entry.code) {
    const c = document.createElement('span');
    c.className = 'code';
    c.textContent = entry.code;
    msg.appendChild(c);
  }
  msg.append(entry.message);
  const close = document.createElement('button');
  close.type = 'button';
  close.setAttribute('aria-label', 'Dismiss');
  close.textContent = '×';
  close.addEventListener('click', () => remove(entry));
  el.append(msg, close);
  entry.el = el;
  container()?.appendChild(el);
  alerts.push(entry);
  while (alerts.length > 5) remove(alerts[0]);
  arm(entry, entry);
  return entry;
}

function arm(entry, a) {
  if (a.sticky) return;
  const ms = a.timeout ?? (a.level === 'info' ? 4000 : 12000);
  entry.timer = setTimeout(() => remove(entry), ms);
}

function remove(entry) {
  const i = alerts.indexOf(entry);
  if (i >= 0) alerts.splice(i, 1);
  clearTimeout(entry.timer);
  entry.el?.remove();
}

export function dismissAlert(key) {
  for (const a of alerts.filter((x) => x.key === key)) remove(a);
}
