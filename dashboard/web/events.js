// The Events panel: the server's status messages and the page's own (connection, restarts).
import { $, el } from './dom.js';
import { clockTime } from './format.js';
import { dash } from './probe.js';

const EVENT_LOG_CAP = 500;
const LEVEL_NAME = { 0: 'info', 1: 'warning', 2: 'error', page: 'page' };

// entry: {level: 0/1/2 (the status message's) or 'page', message}.
export function addEvent(entry) {
  const list = $('event-log');
  const level = LEVEL_NAME[entry.level] || 'info';
  const k = dash.lastK;
  const item = el('li', { class: 'event level-' + level, 'data-level': String(entry.level) }, [
    el('time', { text: clockTime(new Date()), class: 'event-time' }),
    el('span', { class: 'event-k', text: k === null ? '' : 'k ' + k }),
    el('span', { class: 'event-level', text: level }),
    el('span', { class: 'event-message', text: entry.message }),
  ]);
  list.insertBefore(item, list.firstChild);   // newest on top
  while (list.childElementCount > EVENT_LOG_CAP) list.removeChild(list.lastElementChild);
  dash.eventCount++;
  $('event-count').textContent = list.childElementCount + (dash.eventCount > list.childElementCount ? ' shown of ' + dash.eventCount : '') + ' entries';
}

export function onStatus(msg) {
  addEvent({ level: msg.level, message: String(msg.message || '') });
}
