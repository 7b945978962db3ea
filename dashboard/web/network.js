// The header's run figures (period, time, filter state, rms error, running cost, processes)
// and the Network panel's process table and counters (netkf/estimate, netkf/network).
import { $, el } from './dom.js';
import { fmt, isNum } from './format.js';
import { store } from './state.js';

export function renderHeader() {
  const e = store.latestEstimate;
  $('period').textContent = e && isNum(e.k) ? String(e.k) : '—';
  $('time').textContent = e && isNum(e.t) ? e.t.toFixed(2) + ' s' : '—';
  const state = $('filter-state');
  state.textContent = e ? String(e.state) : '—';
  state.dataset.state = e ? String(e.state) : '';
  const nw = store.latestNetwork;
  $('rms-error').textContent = nw ? fmt(nw.rms_error, 3) : '—';
  // Closed loop: the running mean cost, beside the theory's bounds on J when it has them
  // (acknowledged inputs, LQR weights); the summary's `cost` at the end of the run.
  const cost = nw && isNum(nw.mean_cost) ? nw.mean_cost : null;
  $('running-cost-stat').hidden = cost === null;
  const costCell = $('running-cost');
  if (cost !== null) {
    const act = store.latestTheory && store.latestTheory.configured && store.latestTheory.configured.actuation;
    const bounds = act && isNum(act.cost_lower) && isNum(act.cost_upper)
      ? ' (J ∈ [' + fmt(act.cost_lower, 3) + ', ' + fmt(act.cost_upper, 3) + '])' : '';
    costCell.textContent = fmt(cost, 4) + bounds;
    costCell.dataset.value = String(cost);
    costCell.dataset.periods = String(nw.periods_costed);
  }
  if (nw && Array.isArray(nw.processes)) {
    const running = nw.processes.filter((p) => p.running).length;
    const restarts = nw.processes.reduce((sum, p) => sum + (p.restarts | 0), 0);
    const summary = $('processes-summary');
    summary.textContent = running + '/' + nw.processes.length + ' running' + (restarts ? ', ' + restarts + ' restarts' : '');
    summary.dataset.state = running === nw.processes.length ? 'ok' : 'down';
  }
}

export function renderNetwork() {
  const nw = store.latestNetwork;
  if (!nw) return;
  const body = document.querySelector('#process-table tbody');
  body.replaceChildren(...(nw.processes || []).map((p) => el('tr', { class: p.running ? '' : 'down' }, [
    el('td', { text: String(p.name), title: String(p.name) }), el('td', { text: String(p.host || '') }), el('td', { text: String(p.pid) }),
    el('td', { text: p.running ? 'yes' : 'no' }), el('td', { text: String(p.restarts) })])));
  $('network-counters').textContent = 'estimates ' + nw.estimates + ' · mean Tr P ' + fmt(nw.mean_trace_P, 3) +
    ' · mean Tr P k|k−1 ' + fmt(nw.mean_trace_P_pred, 3) + ' · late ' + nw.late_total + ' · rejected ' + nw.rejected_total +
    ' · invalid samples ' + nw.invalid_samples;
}
