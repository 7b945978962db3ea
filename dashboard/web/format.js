// Numbers and times as the page writes them.

export function isNum(v) { return typeof v === 'number' && Number.isFinite(v); }

export function fmt(v, digits) {
  if (v === null || v === undefined) return '—';
  if (!isNum(v)) return String(v);
  const a = Math.abs(v);
  if (a !== 0 && (a >= 1e5 || a < 1e-3)) return v.toExponential(2);
  return v.toFixed(digits === undefined ? 3 : digits);
}

// An arrival rate: always three decimals (a rate near 0 is no exponent); 'not yet' when unknown.
export function rateText(v) { return isNum(v) ? v.toFixed(3) : 'not yet'; }

export function fmtTrace(v, unboundedText) { return v === null || v === undefined ? unboundedText : fmt(v, 3); }

export function clockTime(date) {
  return date.toTimeString().slice(0, 8);
}
