// DOM helpers: text always goes in through textContent (the data is untrusted).
export function el(tag, className) {
  const node = document.createElement(tag);
  if (className) node.className = className;
  return node;
}

export function text(tag, value, className) {
  const node = el(tag, className);
  node.textContent = value == null ? '' : String(value);
  return node;
}

// A number for display: 4 significant digits, or an exponent where that hides it.
export function fmt(v) {
  if (v == null || !Number.isFinite(v)) return String(v);
  const a = Math.abs(v);
  return a !== 0 && (a < 1e-3 || a >= 1e5) ? v.toExponential(3) : String(+v.toPrecision(4));
}

// The plots' line colours, in the order series get them.
export const PALETTE = ['#1f77b4', '#d62728', '#2ca02c', '#ff7f0e', '#9467bd', '#8c564b', '#e377c2',
                 '#7f7f7f', '#bcbd22', '#17becf'];
