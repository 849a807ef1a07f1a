// The run's plots (uPlot) over its time: hovering one shows every plot's values at that time,
// a click moves the timeline there, and a vertical line marks the timeline's time.
import uPlot from 'uplot';
import { el, text, fmt, PALETTE } from './dom.js';

export class RunPlots {
  constructor(parent, data, seek) {
    this.t = data.runs[0].t;
    this.marker = this.t[0];
    this.plots = [];
    const sync = uPlot.sync('spacearm');
    for (const plot of data.plots || []) {
      const box = el('div', 'plot');
      box.append(text('h2', plot.title + (plot.unit ? ' [' + plot.unit + ']' : '')));
      parent.append(box);
      const series = [{ label: 't [s]', value: (u, v) => (v == null ? '-' : fmt(v)) }];
      plot.labels.forEach((label, i) =>
        series.push({ label, stroke: PALETTE[i % PALETTE.length], width: 1.5,
                      value: (u, v) => (v == null ? '-' : fmt(v)) }));
      const options = {
        width: 420, height: 170, series, pxAlign: 0,
        scales: { x: { time: false } },
        axes: [{ values: (u, vs) => vs.map(fmt) }, { size: 64, space: 18, values: (u, vs) => vs.map(fmt) }],
        cursor: { sync: { key: sync.key } },
        hooks: { draw: [(u) => this.drawMarker(u)] },
      };
      const u = new uPlot(options, [this.t, ...plot.series], box);
      u.over.addEventListener('click', () => {
        if (u.cursor.left >= 0) seek(u.posToVal(u.cursor.left, 'x'));
      });
      this.plots.push(u);
    }
    for (const note of data.plot_notes || []) parent.append(text('p', note, 'note'));
    const resize = () => {
      const w = Math.max(260, parent.clientWidth - 8);
      for (const u of this.plots) u.setSize({ width: w, height: 170 });
    };
    new ResizeObserver(resize).observe(parent);
  }

  drawMarker(u) {
    const x = Math.round(u.valToPos(this.marker, 'x', true));
    const ctx = u.ctx;
    ctx.save();
    ctx.strokeStyle = '#000';
    ctx.lineWidth = 1;
    ctx.beginPath();
    ctx.moveTo(x, u.bbox.top);
    ctx.lineTo(x, u.bbox.top + u.bbox.height);
    ctx.stroke();
    ctx.restore();
  }

  mark(t) {
    this.marker = t;
    for (const u of this.plots) u.redraw(false, false);
  }
}
