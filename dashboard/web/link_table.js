// The link table, above CARD_LINK_LIMIT links: a row per link (search, sort, "show more"),
// and the card of the link selected in it.
import { CONTROL_LINK_ID, MODEL_LABEL, modelKeys, OBSERVED_WINDOW_SAMPLES, WINDOW_KEY } from './constants.js';
import { getParameters, subscribeParameterUpdates } from './connection.js';
import { $, el } from './dom.js';
import { fmt, isNum, rateText } from './format.js';
import { recentFitText } from './link_cards.js';
import { dash } from './probe.js';
import { redraw } from './redraw.js';
import { store } from './state.js';

const TABLE_ROWS = 100;           // rows the link table shows ("show more" adds as many)

// The columns of the table mode: what each shows of a link's status and how it sorts
// (null sorts first: a link that has not reported is the one to look at).
const LINK_COLUMNS = [
  { key: 'link', label: 'link', value: (l) => l.id, text: (l) => l.name },
  { key: 'model', label: 'model', value: (l) => modelText(l), text: (l) => modelText(l) },
  { key: 'configured', label: 'λ configured', title: '(1 − loss) · P(in time)', rate: 'configured_arrival_rate' },
  { key: 'since', label: 'λ since change', title: 'observed arrival rate since the link\'s model was set: in time / samples',
    rate: 'observed_arrival_rate_since_change' },
  { key: 'window', label: WINDOW_KEY, title: 'observed arrival rate over the latest reports holding at least ' +
    OBSERVED_WINDOW_SAMPLES + ' samples', rate: 'observed_arrival_rate_window' },
  { key: 'shortfall', label: 'λ configured − since change', title: 'how far the link runs below its model',
    value: (l) => shortfall(l), text: (l) => fmt(shortfall(l), 3) },
  { key: 'late', label: 'late share', title: 'late samples / samples the estimator received from the link',
    rate: 'late_fraction' },
  { key: 'samples', label: 'samples', title: 'samples that entered the link since its model was set',
    value: (l) => statusNumber(l, 'samples_in'), text: (l) => fmt(statusNumber(l, 'samples_in'), 0) },
  { key: 'fit', label: 'fitted', title: 'the loss model the link\'s last samples show (bernoulli or simple Gilbert, by AIC)',
    value: (l) => (l.status && l.status.recent_fit ? l.status.recent_fit.loss : null),
    text: (l) => (l.status ? recentFitText(l.status.recent_fit) : '—') },
];
for (const column of LINK_COLUMNS) {
  if (!column.rate) continue;
  column.value = (l) => statusNumber(l, column.rate);
  column.text = (l) => (l.status ? rateText(statusNumber(l, column.rate)) : '—');
}
const linkTable = { sort: 'since', descending: false, query: '', shown: TABLE_ROWS, rowsShown: [] };

// A new scenario's links: the first rows again.
export function resetLinkTable() { linkTable.shown = TABLE_ROWS; }

function statusNumber(link, field) { return link.status && isNum(link.status[field]) ? link.status[field] : null; }
function shortfall(link) {
  const configured = statusNumber(link, 'configured_arrival_rate');
  const observed = statusNumber(link, 'observed_arrival_rate_since_change');
  return configured !== null && observed !== null ? configured - observed : null;
}
function modelText(link) {
  const st = link.status || {};
  const model = MODEL_LABEL[st.model] ? st.model : link.model;
  // Before a status: the loss of a model that has one as a key (as core's describe_link_model
  // reads it), i.e. a Bernoulli link's.
  const loss = isNum(st.stationary_loss) ? st.stationary_loss : (modelKeys(model).includes('loss') ? link.params.loss : null);
  return (MODEL_LABEL[model] || String(model)) + (isNum(loss) ? ' ' + fmt(loss, 3) : '');
}

// The search: terms separated by spaces or commas, a link shown when any term matches: an
// id's beginning ("30": 30, 300-309, 3000-3099), a range of ids ("100-163"), or a word in its
// model or fitted model ("gilbert", "control").
function linkMatcher(query) {
  const terms = query.toLowerCase().split(/[\s,]+/).filter(Boolean);
  if (!terms.length) return () => true;
  const tests = terms.map((term) => {
    const range = /^(-?\d+)-(-?\d+)$/.exec(term);
    if (range) {
      const lo = Math.min(Number(range[1]), Number(range[2]));
      const hi = Math.max(Number(range[1]), Number(range[2]));
      return (l) => l.id >= lo && l.id <= hi;
    }
    if (/^-?\d+$/.test(term)) return (l) => l.name.startsWith(term);
    return (l) => (l.name + ' ' + modelText(l) + ' ' + (l.status ? recentFitText(l.status.recent_fit) : ''))
      .toLowerCase().includes(term);
  });
  return (l) => tests.some((test) => test(l));
}

function compareLinks(column, descending) {
  return (a, b) => {
    const x = column.value(a);
    const y = column.value(b);
    if (x === null || y === null) return x === null && y === null ? a.id - b.id : (x === null ? -1 : 1);
    const order = typeof x === 'string' ? x.localeCompare(y) : x - y;
    return (descending ? -order : order) || a.id - b.id;
  };
}

export function setupLinkTable() {
  const head = $('link-table').tHead.rows[0];
  head.replaceChildren(...LINK_COLUMNS.map((column) => {
    const button = el('button', { type: 'button', 'data-sort': column.key, text: column.label });
    if (column.title) button.title = column.title + ' — sort by it';
    button.addEventListener('click', () => {
      linkTable.descending = linkTable.sort === column.key ? !linkTable.descending : false;
      linkTable.sort = column.key;
      redraw('links');
    });
    return el('th', { scope: 'col', 'data-sort': column.key }, [button]);
  }));
  $('link-search').addEventListener('input', (event) => {
    linkTable.query = event.target.value;
    linkTable.shown = TABLE_ROWS;
    redraw('links');
  });
  $('link-table-more').addEventListener('click', () => {
    linkTable.shown += TABLE_ROWS;
    redraw('links');
  });
  const body = $('link-table').tBodies[0];
  const pick = (event) => {
    const row = event.target.closest('tr[data-link]');
    if (row) selectLink(row.dataset.link === 'control' ? CONTROL_LINK_ID : Number(row.dataset.link));
  };
  body.addEventListener('click', pick);
  body.addEventListener('keydown', (event) => { if (event.key === 'Enter' || event.key === ' ') { event.preventDefault(); pick(event); } });
}

// Table mode: show the card of one link (its parameters read and followed while shown).
function selectLink(id) {
  const link = store.links.get(id);
  if (!link || store.selectedLink === id) return;
  const previous = store.links.get(store.selectedLink);
  if (previous) previous.unmount();
  store.selectedLink = id;
  $('link-table-hint').hidden = true;
  link.mount($('links'));
  getParameters(link.parameterNames(), 'netkf-dashboard-select-' + link.name);
  subscribeParameterUpdates();
  redraw('links');
}

export function renderLinkTable() {
  const started = performance.now();
  const column = LINK_COLUMNS.find((c) => c.key === linkTable.sort) || LINK_COLUMNS[0];
  const matches = linkMatcher(linkTable.query);
  const rows = [...store.links.values()].filter(matches).sort(compareLinks(column, linkTable.descending));
  const shown = rows.slice(0, linkTable.shown);
  linkTable.rowsShown = shown.map((l) => l.name);
  $('link-table').tBodies[0].replaceChildren(...shown.map((l) => {
    const selected = l.id === store.selectedLink;
    return el('tr', { 'data-link': l.name, tabindex: '0', class: selected ? 'selected' : '', 'aria-selected': String(selected) },
      LINK_COLUMNS.map((c) => el('td', { 'data-col': c.key, text: c.text(l) })));
  }));
  for (const th of $('link-table').tHead.rows[0].cells) {
    const sorted = th.dataset.sort === column.key;
    th.setAttribute('aria-sort', sorted ? (linkTable.descending ? 'descending' : 'ascending') : 'none');
  }
  $('link-table-count').textContent = store.links.size + ' links' +
    (linkTable.query.trim() ? ', ' + rows.length + ' match' : '') + ', showing ' + shown.length +
    ', by ' + column.label + (linkTable.descending ? ' (highest first)' : ' (lowest first)');
  $('link-table-more').hidden = rows.length <= shown.length;
  dash.linkTableMs = Math.round((performance.now() - started) * 10) / 10;
}
