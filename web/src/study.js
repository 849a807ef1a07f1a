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
    for (let j = 0; j < g.ny; ++j)
      for (let i = 0; i < g.nx; ++i) {
        const v = cells[j * g.nx + i];
        ctx.fillStyle = v == null || !Number.isFinite(v) ? '#ccc' : color(scale.f(v));
        ctx.fillRect(g.left + i * w, g.top + (g.ny - 1 - j) * h, Math.ceil(w), Math.ceil(h));
      }
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
    this.legend.textContent = this.metric().name + ': ' + fmt(scale.lo) + ' (dark) to ' +
      fmt(scale.hi) + ' (light)' + (scale.log ? ', logarithmic colours' : '') +
      '; grey: no value (a failed run)';
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
      cell: (i, j) => this.describe({ i, j }),
      open: (i, j) => (this.open({ i, j }), this.openedRun),
    };
  }
}
