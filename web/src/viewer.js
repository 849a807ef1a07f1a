// The page `spacearm view` writes: it reads the JSON the command embedded
// (<script type="application/json" id="spacearm-data">, docs/viewer.md) and draws a run (the arm
// in three.js, a timeline, plots linked to it) or a study (a heat map of a metric over two
// parameters). Every string of the data reaches the page through textContent, never as markup.
import { el, text } from './dom.js';
import { Timeline } from './timeline.js';
import { ArmScene } from './arm_scene.js';
import { RunPlots } from './plots.js';
import { StudyView } from './study.js';
import uplotCss from 'uplot/dist/uPlot.min.css';
import pageCss from './viewer.css';

function readData() {
  const node = document.getElementById('spacearm-data');
  if (!node) throw new Error('no #spacearm-data element');
  const data = JSON.parse(node.textContent);
  if (data.format !== 'spacearm-view' || data.version !== 1)
    throw new Error('unknown data format ' + String(data.format) + ' ' + String(data.version));
  return data;
}

// The title, the notes (thinning, missing outputs) and the info table: scene, parameters,
// the commands that produced the files and this page.
function header(data) {
  const info = el('table', 'info');
  for (const [label, value] of data.info || []) {
    const row = el('tr');
    row.append(text('th', label), text('td', value));
    info.append(row);
  }
  const notes = el('ul', 'notes');
  for (const note of data.notes || []) notes.append(text('li', note));
  const details = el('details');
  details.append(text('summary', 'scene, parameters, commands'), info);
  const head = el('header');
  head.append(text('h1', data.title), notes, details);
  return head;
}

function main() {
  const style = document.createElement('style');
  style.textContent = uplotCss + '\n' + pageCss;
  document.head.append(style);
  const data = readData();
  document.title = data.title + ' - spacearm view';
  const app = document.getElementById('app');
  app.append(header(data));
  const hook = { ready: false, kind: data.kind, title: data.title, errors: [] };
  window.spacearmView = hook;
  if (data.kind === 'study') {
    const study = new StudyView(app, data);
    Object.assign(hook, study.hook());
  } else {
    const layout = el('div', 'run');
    const left = el('div', 'left');
    const right = el('div', 'right');
    layout.append(left, right);
    app.append(layout);
    const scene = new ArmScene(left, data);
    const timeline = new Timeline(left, data.runs[0].t);
    const legend = data.runs.map((run, i) =>
      (i ? 'translucent, grey path: ' : 'solid, red path: ') + run.file);
    left.append(text('p', legend.join('; ') + '. Drag to ' +
                     (data.space === 'planar' ? 'pan' : 'orbit (right drag: pan)') +
                     ', wheel to zoom.', 'note'));
    const plots = new RunPlots(right, data, (t) => timeline.seek(t));
    timeline.onChange((t) => {
      scene.show(t);
      plots.mark(t);
    });
    timeline.seek(timeline.start);
    Object.assign(hook, {
      frames: data.runs[0].t.length,
      timeRange: [timeline.start, timeline.end],
      setTime: (t) => timeline.seek(t),
      time: () => timeline.time,
      play: () => timeline.play(),
      pause: () => timeline.pause(),
      endEffector: (run = 0) => scene.endEffector(run),
      endEffectors: (run = 0) => scene.endEffectors(run),
      baseShapes: () => scene.baseShapes(),
      view: () => scene.view(),
      render: () => scene.render(),
      plotRanges: () => plots.plots.map((u) => [u.scales.y.min, u.scales.y.max]),
    });
  }
  hook.ready = true;
}

try {
  main();
} catch (e) {
  const app = document.getElementById('app') || document.body;
  app.append(text('pre', 'spacearm view: ' + (e && e.stack ? e.stack : String(e))));
  window.spacearmView = { ready: false, error: String(e) };
  throw e;
}
