// netkf live dashboard: one foxglove.websocket.v1 client of `netkf launch`
// (docs/dashboard.md is the contract: channels, fields, parameters, status messages).
// Plain ES2020 modules, no build step; uPlot is loaded before them as the global `uPlot`.
// This entry module wires them: each topic to its handler, each part of the page to what
// draws it, and the header's controls.
import { buildStateCharts, buildTraceChart, renderTimeCharts } from './charts.js';
import { connect, getParameters, subscribeParameterUpdates } from './connection.js';
import { CONTROL_LINK_ID } from './constants.js';
import { $ } from './dom.js';
import { buildLinks, onLinkStatus, onParameterValues, renderLinkCards } from './link_cards.js';
import { renderLinkTable, resetLinkTable, setupLinkTable } from './link_table.js';
import { renderHeader, renderNetwork } from './network.js';
import { paintWith, pauseCharts, redrawAll } from './redraw.js';
import { renderRegion } from './region.js';
import { renderVerdict } from './stability.js';
import { clearData, onEstimate, onNetwork, onTheory, onTruth, store, takeScenario, view } from './state.js';

// A new scenario builds the page anew: its charts, link cards (or table) and region.
function onScenario(s) {
  if (!takeScenario(s)) return;
  const sensors = Array.isArray(s.sensors) ? s.sensors : [];
  $('scenario-name').textContent = s.name || '(unnamed scenario)';
  $('scenario-name').title = 'scenario ' + (s.name || '') + ', period ' + s.period_ms + ' ms, seed ' + s.seed +
    ', ' + s.state_dim + ' states, ' + sensors.length + ' sensors';
  buildTraceChart();
  buildStateCharts(store.ring.n);
  // The actuation link's card after the sensors': the same controls, for the inputs.
  buildLinks(s.actuation && s.actuation.link
    ? sensors.concat([{ id: CONTROL_LINK_ID, link: s.actuation.link, actuation: s.actuation }]) : sensors);
  resetLinkTable();
  $('assessment').classList.toggle('no-final', !store.fuseWithin);
  const twoSensors = sensors.length === 2;
  $('region-box').hidden = !twoSensors;
  $('region-none').hidden = twoSensors;
  document.querySelector('main.grid').classList.toggle('no-region', !twoSensors);
  // New link cards: read their parameters (an earlier answer may have come before them).
  // A table reads them for the card selected.
  if (!store.tableMode) getParameters([], 'netkf-dashboard-scenario');
  subscribeParameterUpdates();
  redrawAll();
}

function setupViewControls() {
  const select = $('window-select');
  view.windowS = Number(select.value) || 30;
  select.addEventListener('change', () => {
    view.windowS = Number(select.value) || 30;
    redrawAll();
  });
  const pause = $('pause-button');
  let paused = false;
  pause.addEventListener('click', () => {
    paused = !paused;
    pause.textContent = paused ? 'Resume' : 'Pause';
    pause.setAttribute('aria-pressed', String(paused));
    document.body.classList.toggle('paused', paused);
    pauseCharts(paused);
  });
  $('clear-button').addEventListener('click', clearData);
}

function start() {
  paintWith({
    header: renderHeader,
    theory: renderVerdict,
    network: renderNetwork,
    timeCharts: renderTimeCharts,
    links() {
      if (store.tableMode) renderLinkTable();
      renderLinkCards();
    },
    region: renderRegion,
  });
  setupViewControls();
  setupLinkTable();
  buildTraceChart();
  renderTimeCharts();
  connect({
    topics: {
      'netkf/scenario': onScenario,
      'netkf/estimate': onEstimate,
      'netkf/truth': onTruth,
      'netkf/link/status': onLinkStatus,
      'netkf/theory': onTheory,
      'netkf/network': onNetwork,
    },
    parameterValues: onParameterValues,
  });
}

if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', start);
else start();
