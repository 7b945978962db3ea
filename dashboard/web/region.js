// The stability region of a two-sensor scenario: the (λ1, λ2) plane, above lambda2_upper
// stable, below lambda2_lower unstable, between undecided by the bounds (netkf/theory's
// region); and the operating point, where the links are now, with its recent trail.
import { canvasContext } from './charts.js';
import { COLOR } from './constants.js';
import { $ } from './dom.js';
import { isNum } from './format.js';
import { store } from './state.js';

const clamp = (v) => Math.min(1, Math.max(0, v));

export function renderRegion() {
  const box = $('region-box');
  if (box.hidden) return;
  const { ctx, width, height } = canvasContext($('region-canvas'), 250);
  const pad = { left: 40, right: 120, top: 10, bottom: 34 };
  const pw = width - pad.left - pad.right;
  const ph = height - pad.top - pad.bottom;
  // The plane in canvas pixels.
  const plane = { ctx, pad, pw, ph, height, X: (v) => pad.left + v * pw, Y: (v) => pad.top + (1 - v) * ph };
  ctx.font = '11px system-ui, sans-serif';
  drawRegionAreas(plane);
  drawAxes(plane);
  const point = operatingPoints();
  if (point.observed) {
    const last = store.regionTrail.last();
    if (!last || last[0] !== point.observed[0] || last[1] !== point.observed[1]) store.regionTrail.push(point.observed);
  }
  drawOperatingPoints(plane, point);
  drawLegend(plane, point);
}

// The stable, undecided and unstable areas and the bounds' curves.
function drawRegionAreas({ ctx, X, Y }) {
  const th = store.latestTheory;
  const region = th && Array.isArray(th.region) ? th.region.filter((p) => isNum(p.lambda1)).sort((a, b) => a.lambda1 - b.lambda1) : [];
  if (region.length < 2) {
    ctx.fillStyle = COLOR.axis;
    ctx.fillText('waiting for netkf/theory.region', X(0.2), Y(0.5));
    return;
  }
  // A missing upper curve means no λ2 is proven stable; a missing lower, none proven unstable.
  const lower = region.map((p) => [p.lambda1, isNum(p.lambda2_lower) ? clamp(p.lambda2_lower) : 0]);
  const upper = region.map((p) => [p.lambda1, isNum(p.lambda2_upper) ? clamp(p.lambda2_upper) : 1]);
  const fillBetween = (a, b, color) => {
    ctx.beginPath();
    a.forEach(([x, y], i) => (i ? ctx.lineTo(X(x), Y(y)) : ctx.moveTo(X(x), Y(y))));
    for (let i = b.length - 1; i >= 0; i--) ctx.lineTo(X(b[i][0]), Y(b[i][1]));
    ctx.closePath();
    ctx.fillStyle = color;
    ctx.fill();
  };
  const x0 = region[0].lambda1;
  const x1 = region[region.length - 1].lambda1;
  fillBetween([[x0, 0], [x1, 0]], lower, COLOR.unstable);
  fillBetween(lower, upper, COLOR.undecided);
  fillBetween(upper, [[x0, 1], [x1, 1]], COLOR.stable);
  const curve = (pts, color) => {
    ctx.beginPath();
    pts.forEach(([x, y], i) => (i ? ctx.lineTo(X(x), Y(y)) : ctx.moveTo(X(x), Y(y))));
    ctx.strokeStyle = color;
    ctx.lineWidth = 1.5;
    ctx.stroke();
  };
  curve(lower, COLOR.lowerCurve);
  curve(upper, COLOR.upperCurve);
}

function drawAxes({ ctx, pw, ph, height, X, Y }) {
  ctx.strokeStyle = COLOR.axis;
  ctx.lineWidth = 1;
  ctx.strokeRect(X(0) + 0.5, Y(1) + 0.5, pw, ph);
  ctx.fillStyle = COLOR.axis;
  for (let v = 0; v <= 1.0001; v += 0.25) {
    ctx.textAlign = 'center';
    ctx.fillText(v.toFixed(2), X(v), Y(0) + 13);
    ctx.textAlign = 'right';
    ctx.fillText(v.toFixed(2), X(0) - 4, Y(v) + 4);
  }
  const ids = store.sensorIds;
  ctx.textAlign = 'center';
  ctx.fillText('λ1 (arrival rate of link ' + (ids[0] !== undefined ? ids[0] : 1) + ')', X(0.5), height - 4);
  ctx.save();
  ctx.translate(10, Y(0.5));
  ctx.rotate(-Math.PI / 2);
  ctx.fillText('λ2 (link ' + (ids[1] !== undefined ? ids[1] : 2) + ')', 0, 0);
  ctx.restore();
}

// Operating points: configured (filled) and observed (ring, with its recent trail).
function drawOperatingPoints({ ctx, X, Y }, point) {
  ctx.fillStyle = COLOR.observed;
  store.regionTrail.forEach((p, i) => {
    ctx.globalAlpha = 0.1 + 0.4 * (i / store.regionTrail.cap);
    ctx.beginPath();
    ctx.arc(X(clamp(p[0])), Y(clamp(p[1])), 2.5, 0, 2 * Math.PI);
    ctx.fill();
  });
  ctx.globalAlpha = 1;
  if (point.observed) {
    ctx.beginPath();
    ctx.arc(X(clamp(point.observed[0])), Y(clamp(point.observed[1])), 6, 0, 2 * Math.PI);
    ctx.strokeStyle = COLOR.observed;
    ctx.lineWidth = 2.5;
    ctx.stroke();
  }
  if (point.configured) {
    ctx.beginPath();
    ctx.arc(X(clamp(point.configured[0])), Y(clamp(point.configured[1])), 5, 0, 2 * Math.PI);
    ctx.fillStyle = COLOR.truth;
    ctx.fill();
  }
}

// The legend on the right, with the two points' coordinates.
function drawLegend({ ctx, pad, pw }, point) {
  const lx = pad.left + pw + 12;
  let ly = pad.top + 12;
  const legend = (draw, text) => { draw(lx, ly); ctx.fillStyle = COLOR.axis; ctx.textAlign = 'left'; ctx.fillText(text, lx + 18, ly + 4); ly += 18; };
  const swatch = (color) => (x, y) => { ctx.fillStyle = color; ctx.fillRect(x, y - 5, 12, 10); };
  legend(swatch(COLOR.stable), 'stable');
  legend(swatch(COLOR.undecided), 'undecided');
  legend(swatch(COLOR.unstable), 'unstable');
  legend((x, y) => { ctx.beginPath(); ctx.arc(x + 6, y, 5, 0, 2 * Math.PI); ctx.fillStyle = COLOR.truth; ctx.fill(); }, 'configured');
  legend((x, y) => { ctx.beginPath(); ctx.arc(x + 6, y, 5, 0, 2 * Math.PI); ctx.strokeStyle = COLOR.observed; ctx.lineWidth = 2.5; ctx.stroke(); }, 'observed (since change)');
  ly += 6;
  const fmtPoint = (p) => (p ? '(' + p[0].toFixed(2) + ', ' + p[1].toFixed(2) + ')' : '—');
  ctx.fillStyle = COLOR.axis;
  ctx.fillText('conf ' + fmtPoint(point.configured), lx, ly); ly += 15;
  ctx.fillText('obs  ' + fmtPoint(point.observed), lx, ly);
}

// Arrival rates of the two links: from the link status (updated right after a change),
// else from the last theory assessment. Observed: since change, the rate the theory assesses.
function operatingPoints() {
  const ids = store.sensorIds;
  const pick = (field, assessment) => {
    const values = ids.map((id) => {
      const link = store.links.get(id);
      return link && link.status && isNum(link.status[field]) ? link.status[field] : null;
    });
    if (values.every(isNum)) return values;
    const rates = assessment && assessment.arrival_rates;
    return Array.isArray(rates) && rates.length === ids.length && rates.every(isNum) ? rates : null;
  };
  const th = store.latestTheory || {};
  return {
    configured: pick('configured_arrival_rate', th.configured),
    observed: pick('observed_arrival_rate_since_change', th.observed),
  };
}
