// The Stability panel: the verdict and the assessment table of the configured, observed
// (since change) and final-estimate assessments of netkf/theory.
import { CARD_LINK_LIMIT } from './constants.js';
import { $, el } from './dom.js';
import { fmt, fmtTrace, isNum, rateText } from './format.js';
import { dash } from './probe.js';
import { store } from './state.js';

const STABLE_TEXT = { yes: 'stable', no: 'unstable', unknown: 'undecided' };

export function renderVerdict() {
  const th = store.latestTheory;
  const verdict = $('verdict');
  if (!th) return;
  const conf = th.configured || null;
  const obs = th.observed || null;
  const confStable = conf ? String(conf.stable) : 'unknown';
  const obsStable = obs ? String(obs.stable) : 'none';
  const fin = store.fuseWithin ? (th.final_estimate || null) : null;
  const finStable = fin ? String(fin.stable) : 'none';
  verdict.dataset.configured = confStable;
  verdict.dataset.observed = obsStable;
  verdict.dataset.final = finStable;
  dash.finalVerdict = fin ? finStable : null;
  verdict.replaceChildren(
    el('span', { class: 'verdict-main', 'data-stable': confStable, text: STABLE_TEXT[confStable] || confStable }),
    document.createTextNode(' '),
    el('span', { class: 'verdict-detail', text: 'configured: ' + (STABLE_TEXT[confStable] || confStable) +
      ' · observed (since change): ' + (obs ? (STABLE_TEXT[obsStable] || obsStable) : 'not yet known') +
      (store.fuseWithin ? ' · final estimates: ' + (fin ? (STABLE_TEXT[finStable] || finStable) : 'not yet known') : '') }),
    document.createTextNode(' '),
    el('span', { class: 'verdict-k muted small', text: '(at k ' + th.k + ')' }));
  const set = (field, text, cls) => {
    const cell = document.querySelector('#assessment [data-field="' + field + '"]');
    cell.textContent = text;
    cell.className = (field.startsWith('fin-') ? 'final-col ' : '') + (cls || '');
  };
  const fill = (prefix, a) => {
    if (!a) {
      for (const f of ['stable', 'markov', 'lower', 'upper', 'rates']) set(prefix + '-' + f, '—');
      return;
    }
    set(prefix + '-stable', STABLE_TEXT[a.stable] || String(a.stable), 'stable-' + a.stable);
    const markov = a.markov_criterion;
    set(prefix + '-markov', isNum(markov) ? fmt(markov, 3) + (markov < 1 ? ' < 1' : ' ≥ 1') : 'n/a',
      isNum(markov) ? (markov < 1 ? 'stable-yes' : 'stable-no') : 'muted');
    set(prefix + '-lower', fmtTrace(a.lower_trace, '∞ (unbounded)'), isNum(a.lower_trace) ? '' : 'stable-no');
    set(prefix + '-upper', fmtTrace(a.upper_trace, a.stable === 'no' ? '∞ (unbounded)' : '∞ / undecided'), isNum(a.upper_trace) ? '' : 'muted');
    // Three decimals, as the link cards show the same rates; many links: their range.
    set(prefix + '-rates', Array.isArray(a.arrival_rates) ? ratesText(a.arrival_rates) : '—');
  };
  fill('conf', conf);
  fill('obs', obs);
  fill('fin', fin);
  const reasons = [];
  if (conf && conf.reason) reasons.push('configured: ' + conf.reason);
  if (obs && obs.reason) reasons.push('observed (since change): ' + obs.reason);
  if (fin && fin.reason) reasons.push('final estimates: ' + fin.reason);
  $('assessment-reason').textContent = reasons.join(' · ');
}

// The assessment's arrival rates (scenario order): each, or, for more links than cards, the
// lowest with its link, the mean and the highest (the link table has each).
function ratesText(rates) {
  if (rates.length <= CARD_LINK_LIMIT || !rates.every(isNum)) return rates.map(rateText).join(', ');
  let lowest = 0;
  let highest = 0;
  rates.forEach((r, i) => { if (r < rates[lowest]) lowest = i; if (r > rates[highest]) highest = i; });
  const mean = rates.reduce((a, b) => a + b, 0) / rates.length;
  const id = (i) => (i < store.sensorIds.length ? ' (link ' + store.sensorIds[i] + ')' : '');
  return rates.length + ' links: lowest ' + rateText(rates[lowest]) + id(lowest) + ', mean ' + rateText(mean) +
    ', highest ' + rateText(rates[highest]);
}
