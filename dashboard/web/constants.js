// What more than one module of the dashboard page needs: the links' names and models, the
// observed-rate window and the colours (docs/dashboard.md is the contract).
import { linkModelsOf } from './link_models.js';

// Above this many links the page shows a table of them and the card of the one selected:
// thousands of cards, each a chart and a dozen controls, would not draw.
export const CARD_LINK_LIMIT = 16;
// The actuation link (plant.control.link) is link "control": id -1 where links are numbered.
export const CONTROL_LINK_ID = -1;
export const linkName = (id) => (id === CONTROL_LINK_ID ? 'control' : String(id));
// The link models as the server describes them (the channel catalogue: the link status
// schema's `model` property, x-netkf-models; docs/dashboard.md): name -> {label, keys, example},
// in the server's order, and name -> label. Set from each advertise, before any message comes.
export const LINK_MODELS = new Map();
export const MODEL_LABEL = {};
// The models of a link status channel's schema (JSON text); false when it has none.
export function takeLinkModels(schemaText) {
  const models = linkModelsOf(schemaText);
  if (!models) return false;
  LINK_MODELS.clear();
  for (const key of Object.keys(MODEL_LABEL)) delete MODEL_LABEL[key];
  for (const { name, label, keys, example } of models) {
    LINK_MODELS.set(name, { label, keys, example });
    MODEL_LABEL[name] = label;
  }
  return true;
}
// The parameter keys of a model ([] for a name the server did not describe).
export const modelKeys = (model) => (LINK_MODELS.has(model) ? LINK_MODELS.get(model).keys : []);
export const OBSERVED_WINDOW_SAMPLES = 1000;  // the observed rate window's least span (kWindowSamples, cli/live/include/netkf/cli/live/observed_rate.hpp)
export const WINDOW_KEY = 'λ last ≥' + OBSERVED_WINDOW_SAMPLES + ' samples';

export const COLOR = {
  truth: '#1d232b',
  estimate: '#1f6fd1',
  sigmaBand: 'rgba(31, 111, 209, 0.16)',
  sigmaEdge: 'rgba(31, 111, 209, 0.35)',
  tracePred: '#6b3fb8',
  traceFiltered: 'rgba(107, 63, 184, 0.35)',
  configured: '#1e8a4c',
  configuredBand: 'rgba(30, 138, 76, 0.12)',
  observed: '#d9731a',
  observedWindow: '#8a4b12',
  observedBand: 'rgba(217, 115, 26, 0.08)',
  diverging: 'rgba(214, 48, 49, 0.10)',
  axis: '#4a5563',
  grid: 'rgba(0, 0, 0, 0.07)',
  stable: 'rgba(30, 138, 76, 0.20)',
  undecided: 'rgba(230, 170, 40, 0.22)',
  unstable: 'rgba(214, 48, 49, 0.20)',
  lowerCurve: '#b8322f',
  upperCurve: '#1e8a4c',
  final: '#c2185b',                      // late_policy fuse_within: the final (revised) estimates
  finalBand: 'rgba(194, 24, 91, 0.08)',
};
