// The time slider, play/pause, speed and keys. Time stays within the run's first and last
// sample (never extrapolated); listeners get every change.
import { el, text } from './dom.js';

const SPEEDS = [0.1, 0.25, 0.5, 1, 2, 5, 10, 20];
const STEPS = 10000;  // slider positions over the run

export class Timeline {
  constructor(parent, times) {
    this.times = times;
    this.start = times[0];
    this.end = times[times.length - 1];
    this.time = this.start;
    this.speed = 1;
    this.playing = false;
    this.listeners = [];
    const bar = el('div', 'timeline');
    this.button = text('button', 'play');
    this.button.title = 'play / pause (space)';
    this.slider = el('input');
    this.slider.type = 'range';
    this.slider.min = '0';
    this.slider.max = String(STEPS);
    this.slider.title = 'time (arrow keys: a frame; Home, End)';
    this.speedSelect = el('select');
    this.speedSelect.title = 'speed (+ and - keys)';
    for (const s of SPEEDS) {
      const option = text('option', s + 'x');
      option.value = String(s);
      if (s === 1) option.selected = true;
      this.speedSelect.append(option);
    }
    this.readout = text('span', '', 'readout');
    bar.append(this.button, this.slider, this.speedSelect, this.readout);
    parent.append(bar);
    this.button.addEventListener('click', () => (this.playing ? this.pause() : this.play()));
    this.slider.addEventListener('input', () => {
      this.pause();
      this.seek(this.start + (this.end - this.start) * (+this.slider.value / STEPS));
    });
    this.speedSelect.addEventListener('change', () => (this.speed = +this.speedSelect.value));
    document.addEventListener('keydown', (e) => this.key(e));
  }

  onChange(f) {
    this.listeners.push(f);
  }

  seek(t) {
    if (!Number.isFinite(t)) return;
    this.time = Math.min(this.end, Math.max(this.start, t));
    const span = this.end - this.start;
    this.slider.value = String(span > 0 ? Math.round(((this.time - this.start) / span) * STEPS) : 0);
    this.readout.textContent =
      't = ' + this.time.toFixed(3) + ' s of ' + this.end.toFixed(3) + ' s';
    for (const f of this.listeners) f(this.time);
  }

  play() {
    if (this.playing) return;
    if (this.time >= this.end) this.seek(this.start);
    this.playing = true;
    this.button.textContent = 'pause';
    let last = performance.now();
    const tick = (now) => {
      if (!this.playing) return;
      this.seek(this.time + ((now - last) / 1000) * this.speed);
      last = now;
      if (this.time >= this.end) this.pause();
      else requestAnimationFrame(tick);
    };
    requestAnimationFrame(tick);
  }

  pause() {
    this.playing = false;
    this.button.textContent = 'play';
  }

  // The frame before or after the current time.
  step(direction) {
    const ts = this.times;
    let k = 0;
    while (k < ts.length - 1 && ts[k + 1] <= this.time) ++k;
    if (direction > 0) this.seek(ts[Math.min(ts.length - 1, ts[k] > this.time ? k : k + 1)]);
    else this.seek(ts[ts[k] < this.time ? k : Math.max(0, k - 1)]);
  }

  key(e) {
    const tag = e.target && e.target.tagName;
    if ((tag === 'INPUT' || tag === 'SELECT') && e.key !== ' ') return;
    if (tag === 'BUTTON' && e.key === ' ') return;  // the button's own click plays or pauses
    const index = SPEEDS.indexOf(this.speed);
    const actions = {
      ' ': () => (this.playing ? this.pause() : this.play()),
      ArrowRight: () => (this.pause(), this.step(1)),
      ArrowLeft: () => (this.pause(), this.step(-1)),
      Home: () => this.seek(this.start),
      End: () => this.seek(this.end),
      '+': () => this.setSpeed(SPEEDS[Math.min(SPEEDS.length - 1, index + 1)]),
      '-': () => this.setSpeed(SPEEDS[Math.max(0, index - 1)]),
    };
    const action = actions[e.key];
    if (!action) return;
    e.preventDefault();
    action();
  }

  setSpeed(s) {
    this.speed = s;
    this.speedSelect.value = String(s);
  }
}
