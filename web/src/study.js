// A study (spacearm sweep's results.csv): a metric over two parameters as a heat map (as the
// paper's Figures 9-10), or over one as a line; hovering shows a cell's values, a click opens
// the run's time series where the study wrote them (time_series).
import uPlot from 'uplot';
import { el, text, fmt, PALETTE } from './dom.js';

// Viridis at five stops, interpolated.
const STOPS = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];
function color(f) {
  const x = Math.min(1, Math.max(0, f)) * (STOPS.length - 1);
  const i = Math.min(STOPS.length - 2, Math.floor(x)), w = x - i;
  const c = STOPS[i].map((v, k) => Math.round(v + (STOPS[i + 1][k] - v) * w));
  return 'rgb(' + c.join(',') + ')';
}

// Maps a metric's finite values to [0, 1]: logarithmic where all are positive over more than two
// decades.
function scaleOf(values) {
  const finite = values.filter((v) => v != null && Number.isFinite(v));
  if (!finite.length) return { f: () => 0, log: false, lo: 0, hi: 0 };
  let lo = Math.min(...finite), hi = Math.max(...finite);
  const log = lo > 0 && hi / lo > 100;
  const g = log ? Math.log10 : (v) => v;
  const a = g(lo), b = g(hi);
  return { f: (v) => (b > a ? (g(v) - a) / (b - a) : 0.5), log, lo, hi };
}

// Pearson's correlation of two equally long arrays over the entries where both are finite;
// null where fewer than three such, or either does not vary.
export function correlation(a, b) {
  let n = 0, sa = 0, sb = 0;
  for (let i = 0; i < a.length; ++i)
    if (Number.isFinite(a[i]) && Number.isFinite(b[i])) ++n, sa += a[i], sb += b[i];
  if (n < 3) return null;
  const ma = sa / n, mb = sb / n;
  let ab = 0, aa = 0, bb = 0;
  for (let i = 0; i < a.length; ++i)
    if (Number.isFinite(a[i]) && Number.isFinite(b[i])) {
      const x = a[i] - ma, y = b[i] - mb;
      ab += x * y, aa += x * x, bb += y * y;
    }
  return aa > 0 && bb > 0 ? ab / Math.sqrt(aa * bb) : null;
}

// Every run's own values (data.study.points): a scatter of any parameter or metric against any
// other, coloured by the chosen metric; a histogram of the metric; the parameters ranked by
// |correlation| with it. For random draws, which a map of bins averages away.
class RunsView {
  constructor(box, study, metricOf) {
    const p = study.points;
    this.columns = [
      ...p.parameters.map((name, k) => ({ name, values: p.parameter_values[k], parameter: true })),
      ...study.metrics.map((m, k) => ({ name: m.name, values: p.metric_values[k].map((v) => (v == null ? NaN : v)) })),
    ];
    this.metricOf = metricOf;
    box.append(text('h2', 'runs (' + (p.parameter_values[0] || []).length + ' drawn)'));
    const controls = el('div', 'controls');
    this.x = this.columnSelect(controls, 'x ');
    this.y = this.columnSelect(controls, ' y ');
    box.append(controls);
    this.scatter = el('canvas', 'scatter');
    this.histogram = el('canvas', 'histogram');
    this.ranking = text('div', '', 'ranking');
    box.append(this.scatter, this.histogram, this.ranking);
    for (const s of [this.x, this.y]) s.addEventListener('change', () => this.draw(false));
  }

  columnSelect(parent, label) {
    parent.append(text('label', label));
    const select = el('select');
    this.columns.forEach((c, i) => {
      const option = text('option', c.name);
      option.value = String(i);
      select.append(option);
    });
    parent.append(select);
    return select;
  }

  column(name) {
    return this.columns.find((c) => c.name === name);
  }

  // The parameters by |r| with the metric, largest first.
  ranked() {
    const metric = this.column(this.metricOf()).values;
    return this.columns.filter((c) => c.parameter)
      .map((c) => ({ name: c.name, r: correlation(c.values, metric) }))
      .filter((e) => e.r != null)
      .sort((a, b) => Math.abs(b.r) - Math.abs(a.r));
  }

  // reset: x becomes the parameter that matters most, y the metric.
  draw(reset = true) {
    const metricName = this.metricOf(), ranked = this.ranked();
    if (reset) {
      const first = ranked.length ? ranked[0].name : this.columns[0].name;
      this.x.value = String(this.columns.indexOf(this.column(first)));
      this.y.value = String(this.columns.indexOf(this.column(metricName)));
    }
    this.ranking.textContent = 'parameters by their correlation with ' + metricName + ': ' +
      (ranked.length ? ranked.map((e) => e.name + ' r = ' + e.r.toFixed(3)).join(', ')
        : 'none varies with it');
    this.rankedNow = ranked;
    this.drawScatter();
    this.drawHistogram();
  }

  canvas(node, width, height) {
    const ratio = window.devicePixelRatio || 1;
    node.width = width * ratio, node.height = height * ratio;
    node.style.width = width + 'px', node.style.height = height + 'px';
    const ctx = node.getContext('2d');
    ctx.scale(ratio, ratio);
    ctx.fillStyle = '#fff';
    ctx.fillRect(0, 0, width, height);
    ctx.font = '11px sans-serif';
    return ctx;
  }

  drawScatter() {
    const W = 640, H = 360, L = 70, T = 10, w = 540, h = 300;
    const ctx = this.canvas(this.scatter, W, H);
    const xs = this.columns[+this.x.value], ys = this.columns[+this.y.value];
    const colour = this.column(this.metricOf()).values, scale = scaleOf(colour);
    const range = (v) => {
      const f = v.filter(Number.isFinite);
      const lo = Math.min(...f), hi = Math.max(...f);
      return hi > lo ? [lo, hi] : [lo - 1, lo + 1];
    };
    const [x0, x1] = range(xs.values), [y0, y1] = range(ys.values);
    let drawn = 0, failed = 0;
    for (let i = 0; i < xs.values.length; ++i) {
      const x = xs.values[i], y = ys.values[i];
      if (!Number.isFinite(x) || !Number.isFinite(y)) { ++failed; continue; }
      ctx.fillStyle = Number.isFinite(colour[i]) ? color(scale.f(colour[i])) : '#bbb';
      ctx.fillRect(L + ((x - x0) / (x1 - x0)) * w - 2, T + h - ((y - y0) / (y1 - y0)) * h - 2, 4, 4);
      ++drawn;
    }
    ctx.strokeStyle = '#999';
    ctx.strokeRect(L, T, w, h);
    ctx.fillStyle = '#000';
    ctx.textAlign = 'center';
    ctx.fillText(fmt(x0), L, T + h + 14);
    ctx.fillText(fmt(x1), L + w, T + h + 14);
    ctx.fillText(xs.name, L + w / 2, T + h + 30);
    ctx.textAlign = 'right';
    ctx.fillText(fmt(y1), L - 4, T + 8);
    ctx.fillText(fmt(y0), L - 4, T + h);
    ctx.fillText(ys.name, L - 4, T + h / 2);
    this.scatterCounts = { drawn, failed };
  }

  drawHistogram() {
    const W = 640, H = 160, L = 70, T = 10, w = 540, h = 110, bins = 30;
    const ctx = this.canvas(this.histogram, W, H);
    const metric = this.column(this.metricOf());
    const v = metric.values.filter(Number.isFinite);
    if (!v.length) return;
    const lo = Math.min(...v), hi = Math.max(...v), span = hi > lo ? hi - lo : 1;
    const counts = new Array(bins).fill(0);
    for (const x of v) counts[Math.min(bins - 1, Math.floor(((x - lo) / span) * bins))]++;
    const top = Math.max(...counts);
    ctx.fillStyle = '#3b7dd8';
    counts.forEach((c, k) => ctx.fillRect(L + (k * w) / bins, T + h - (c / top) * h, w / bins - 1, (c / top) * h));
    ctx.fillStyle = '#000';
    ctx.textAlign = 'center';
    ctx.fillText(fmt(lo), L, T + h + 14);
    ctx.fillText(fmt(hi), L + w, T + h + 14);
    ctx.fillText(metric.name + ': ' + v.length + ' runs (most in one bin: ' + top + ')', L + w / 2, T + h + 30);
    this.histogramCounts = counts;
  }
}

export class StudyView {
  constructor(parent, data) {
    this.data = data;
    this.study = data.study;
    const box = el('div', 'study');
    parent.append(box);
    const controls = el('div', 'controls');
    controls.append(text('label', 'metric '));
    this.select = el('select');
    this.study.metrics.forEach((m, i) => {
      const option = text('option', m.name);
      option.value = String(i);
      this.select.append(option);
    });
    // The end effector's error first where the study has it (the paper's figures).
    const preferred = this.study.metrics.findIndex((m) => m.name === 'ee_error');
    if (preferred >= 0) this.select.value = String(preferred);
    controls.append(this.select);
    this.tip = text('div', 'hover a cell', 'hover');
    box.append(controls);
    this.canvas = el('canvas', 'heatmap');
    this.legend = text('div', '', 'legend');
    box.append(this.canvas, this.legend, this.tip);
    this.seriesBox = el('div', 'series');
    box.append(this.seriesBox);
    this.runsView = this.study.points ? new RunsView(box, this.study, () => this.metric().name) : null;
    this.select.addEventListener('change', () => this.draw());
    this.canvas.addEventListener('mousemove', (e) => this.hover(e));
    this.canvas.addEventListener('click', (e) => this.open(this.cellAt(e)));
    this.draw();
  }

  metric() {
    return this.study.metrics[+this.select.value];
  }

  // Geometry of the plot area in canvas pixels.
  layout() {
    const nx = this.study.x.values.length, ny = this.study.y ? this.study.y.values.length : 1;
    return { left: 80, top: 10, width: 560, height: this.study.y ? 420 : 60, nx, ny };
  }

  draw() {
    const g = this.layout();
    const ratio = window.devicePixelRatio || 1;
    this.canvas.width = (g.left + g.width + 20) * ratio;
    this.canvas.height = (g.top + g.height + 50) * ratio;
    this.canvas.style.width = g.left + g.width + 20 + 'px';
    this.canvas.style.height = g.top + g.height + 50 + 'px';
    const ctx = this.canvas.getContext('2d');
    ctx.scale(ratio, ratio);
    ctx.fillStyle = '#fff';
    ctx.fillRect(0, 0, g.left + g.width + 20, g.top + g.height + 50);
    const cells = this.metric().cells;
    const scale = scaleOf(cells);
    const w = g.width / g.nx, h = g.height / g.ny;
    let empty = 0, failed = 0;
    for (let j = 0; j < g.ny; ++j)
      for (let i = 0; i < g.nx; ++i) {
        const k = j * g.nx + i, v = cells[k];
        // A bin no run fell in (white), one whose runs all failed (grey), or the metric's colour.
        const none = this.study.runs[k] == null;
        empty += none;
        failed += !none && (v == null || !Number.isFinite(v));
        ctx.fillStyle = none ? '#fff' : v == null || !Number.isFinite(v) ? '#bbb' : color(scale.f(v));
        ctx.fillRect(g.left + i * w, g.top + (g.ny - 1 - j) * h, Math.ceil(w), Math.ceil(h));
      }
    this.emptyCells = empty;
    this.failedCells = failed;
    ctx.strokeStyle = '#999';
    ctx.strokeRect(g.left, g.top, g.width, g.height);
    // Tick labels at about eight cells per axis, and the parameters' names.
    ctx.fillStyle = '#000';
    ctx.font = '11px sans-serif';
    const every = (n) => Math.max(1, Math.ceil(n / 8));
    ctx.textAlign = 'center';
    for (let i = 0; i < g.nx; i += every(g.nx))
      ctx.fillText(fmt(this.study.x.values[i]), g.left + (i + 0.5) * w, g.top + g.height + 14);
    ctx.font = '13px sans-serif';
    ctx.fillText(this.study.x.name, g.left + g.width / 2, g.top + g.height + 34);
    if (this.study.y) {
      ctx.font = '11px sans-serif';
      ctx.textAlign = 'right';
      for (let j = 0; j < g.ny; j += every(g.ny))
        ctx.fillText(fmt(this.study.y.values[j]), g.left - 4, g.top + (g.ny - 1 - j + 0.5) * h + 4);
      ctx.save();
      ctx.translate(14, g.top + g.height / 2);
      ctx.rotate(-Math.PI / 2);
      ctx.textAlign = 'center';
      ctx.font = '13px sans-serif';
      ctx.fillText(this.study.y.name, 0, 0);
      ctx.restore();
    }
    ctx.textAlign = 'left';
    if (this.runsView) this.runsView.draw();
    this.legend.textContent = this.metric().name + ': ' + fmt(scale.lo) + ' (dark) to ' +
      fmt(scale.hi) + ' (light)' + (scale.log ? ', logarithmic colours' : '') +
      (failed ? '; grey: every run there failed (' + failed + ' cells)' : '') +
      (empty ? '; white: no run fell in the bin (' + empty + ' cells)' : '');
  }

  // The cell under a mouse event: {i, j} or null.
  cellAt(e) {
    const g = this.layout();
    const r = this.canvas.getBoundingClientRect();
    const x = e.clientX - r.left - g.left, y = e.clientY - r.top - g.top;
    if (x < 0 || y < 0 || x >= g.width || y >= g.height) return null;
    return { i: Math.floor((x / g.width) * g.nx), j: g.ny - 1 - Math.floor((y / g.height) * g.ny) };
  }

  describe(cell) {
    const s = this.study, k = cell.j * s.x.values.length + cell.i;
    if (s.runs[k] == null) {
      let where = s.x.name + ' = ' + fmt(s.x.values[cell.i]);
      if (s.y) where += ', ' + s.y.name + ' = ' + fmt(s.y.values[cell.j]);
      return where + ': no run fell in this bin';
    }
    let line = s.x.name + ' = ' + fmt(s.x.values[cell.i]);
    if (s.y) line += ', ' + s.y.name + ' = ' + fmt(s.y.values[cell.j]);
    line += ': ' + this.metric().name + ' = ' + fmt(this.metric().cells[k]);
    if (s.counts[k] > 1) line += ' (mean of ' + s.counts[k] + ' runs)';
    if (s.runs[k] != null) line += '; run ' + s.runs[k];
    if (s.series && s.series[String(s.runs[k])]) line += ' (click: its time series)';
    return line;
  }

  hover(e) {
    const cell = this.cellAt(e);
    this.tip.textContent = cell ? this.describe(cell) : 'hover a cell';
  }

  // Shows run's time series below the map (the study's series/run-*.csv, thinned).
  open(cell) {
    if (!cell) return;
    this.openedRun = null;
    const s = this.study, run = s.runs[cell.j * s.x.values.length + cell.i];
    const series = s.series && s.series[String(run)];
    this.seriesBox.replaceChildren(text('h2', 'run ' + run + ': ' + this.describe(cell)));
    if (!series) {
      this.seriesBox.append(text('p', 'the study wrote no time series for this run (time_series)'));
      return;
    }
    const columns = [{ label: 't [s]' }, ...series.labels.map((label, i) =>
      ({ label, stroke: PALETTE[i % PALETTE.length] }))];
    new uPlot({ width: 600, height: 220, series: columns, scales: { x: { time: false } } },
              [series.t, ...series.values], this.seriesBox);
    this.openedRun = run;
  }

  hook() {
    return {
      metric: () => this.metric().name,
      legend: () => this.legend.textContent,
      cells: () => ({ empty: this.emptyCells, failed: this.failedCells }),
      setMetric: (name) => {
        this.select.value = String(this.study.metrics.findIndex((m) => m.name === name));
        this.draw();
      },
      ranking: () => this.runsView.rankedNow,
      scatter: () => ({ x: this.runsView.columns[+this.runsView.x.value].name,
                        y: this.runsView.columns[+this.runsView.y.value].name,
                        ...this.runsView.scatterCounts }),
      histogram: () => this.runsView.histogramCounts,
      cell: (i, j) => this.describe({ i, j }),
      open: (i, j) => (this.open({ i, j }), this.openedRun),
    };
  }
}
