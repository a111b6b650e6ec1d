// The timeline of the current utterance: words, visemes, the expression curve and the streamed mouth
// opening, over time, with a moving playhead. Drawn on a canvas from stream_start.utterance.

const GUTTER = 86;
const AXIS = 18;
const TRACKS = [
  { key: 'words', label: 'words', h: 22 },
  { key: 'visemes', label: 'visemes', h: 28 },
  { key: 'expressions', label: 'expression', h: 34 },
  { key: 'mouth', label: 'jawOpen', h: 34 },
];

const EXPRESSION_COLORS = {
  joy: '#f4c542',
  smile: '#f7a440',
  sadness: '#5b8def',
  anger: '#e5484d',
  fear: '#9b6bdf',
  disgust: '#46a758',
  surprise: '#12a5c8',
  neutral: '#8b95a5',
  wink: '#e07ac9',
};

function hashHue(s) {
  let h = 0;
  for (const c of s) h = (h * 31 + c.codePointAt(0)) >>> 0;
  return h % 360;
}

// Visemes coloured by articulation, the same colour for a class in every set (zh15 / Oculus).
const VISEME_COLORS = {
  a: '#f08c3a', aa: '#f08c3a',
  o: '#e3b23c', O: '#e3b23c',
  e: '#d6d04a', E: '#d6d04a',
  i: '#9ccf4a', I: '#9ccf4a',
  uv: '#4fc08d', U: '#4fc08d', u: '#4fc08d',
  bpm: '#e5484d', PP: '#e5484d',
  f: '#e06fa5', FF: '#e06fa5',
  dtnl: '#4f8ef7', DD: '#4f8ef7', TH: '#5d9cf0',
  n: '#6c7cf0', nn: '#6c7cf0',
  ng: '#8e6cf0',
  gkh: '#a66cd6', kk: '#a66cd6',
  jqx: '#22b3c4',
  zcs: '#2fa39a', SS: '#2fa39a',
  zhchsh: '#3fb8e0', CH: '#3fb8e0',
  r: '#c98a5a', RR: '#c98a5a',
};

export function visemeColor(name) {
  const n = String(name || '').replace(/^viseme_/, '');
  if (!n || n === 'sil') return '#3a3f4b';
  return VISEME_COLORS[n] || `hsl(${hashHue(n)}, 55%, 55%)`;
}

export function expressionColor(name) {
  return EXPRESSION_COLORS[name] || `hsl(${hashHue(name)}, 60%, 60%)`;
}

function smooth(u) {
  return u <= 0 ? 0 : u >= 1 ? 1 : u * u * (3 - 2 * u);
}

/**
 * The expression level over time from the tags ((name, a, T): reach a/63 in T seconds, hold until the
 * next tag). Returns [{start, end, name, from, to, ramp}] segments.
 */
export function expressionSegments(expressions, duration) {
  const tags = [...(expressions || [])].sort((a, b) => a.start - b.start);
  const segs = [];
  let level = 0;
  for (let i = 0; i < tags.length; i++) {
    const tag = tags[i];
    const end = i + 1 < tags.length ? tags[i + 1].start : Math.max(duration, tag.start + (tag.ramp || 0));
    const to = Math.max(0, Math.min(1, (tag.intensity ?? 0) / 63));
    const seg = { start: tag.start, end, name: tag.name, from: level, to, ramp: Math.max(0, tag.ramp || 0) };
    // The level reached when the next tag interrupts this ramp.
    level = seg.ramp > 0 ? seg.from + (to - seg.from) * smooth((end - tag.start) / seg.ramp) : to;
    segs.push(seg);
  }
  return segs;
}

export class Timeline {
  constructor(canvas) {
    this.canvas = canvas;
    this.ctx = canvas.getContext('2d');
    this.utterance = null;
    this.id = null;
    this.duration = 1;
    this.t = null;
    this.mouth = []; // [t, value] from the received weights
    this.hover = null;
    this.drawn = { id: null, visemes: 0, expressions: 0, words: 0, draws: 0, playhead: null };
    canvas.addEventListener('mousemove', (e) => {
      const r = canvas.getBoundingClientRect();
      this.hover = e.clientX - r.left;
      this.draw();
    });
    canvas.addEventListener('mouseleave', () => {
      this.hover = null;
      this.draw();
    });
    new ResizeObserver(() => this.draw()).observe(canvas);
  }

  /**
   * A new utterance (stream_start): its viseme engine JSON, the stream's duration, and the array the
   * stream's jawOpen values arrive in ([t, value], filled as frames come).
   */
  set(id, utterance, duration, mouth = []) {
    this.id = id;
    this.utterance = utterance || null;
    this.duration = Math.max(0.5, duration || utterance?.duration || 1);
    this.mouth = mouth;
    this.t = null;
    this.draw();
  }

  setTime(t) {
    this.t = t;
    this.draw();
  }

  x(t, w) {
    return GUTTER + (t / this.duration) * (w - GUTTER - 8);
  }

  /** Redraws everything: axis, one row per track, playhead and hover read-out. */
  draw() {
    const c = this.canvas;
    const dpr = window.devicePixelRatio || 1;
    const w = Math.max(1, c.clientWidth);
    const h = Math.max(1, c.clientHeight);
    if (c.width !== Math.round(w * dpr) || c.height !== Math.round(h * dpr)) {
      c.width = Math.round(w * dpr);
      c.height = Math.round(h * dpr);
    }
    const g = this.ctx;
    g.setTransform(dpr, 0, 0, dpr, 0, 0);
    g.clearRect(0, 0, w, h);
    g.fillStyle = '#1b1e25';
    g.fillRect(0, 0, w, h);
    g.font = '11px system-ui, sans-serif';
    g.textBaseline = 'middle';

    const u = this.utterance;
    if (!u) {
      g.fillStyle = '#8b95a5';
      g.fillText('The timeline of the next utterance appears here.', GUTTER, h / 2);
      this.drawn = { ...this.drawn, id: null, draws: this.drawn.draws + 1 };
      return;
    }

    this.drawAxis(g, w, h);
    let y = AXIS + 2;
    const rows = {};
    for (const tr of TRACKS) {
      rows[tr.key] = { y, h: tr.h };
      g.fillStyle = '#aab3c2';
      g.fillText(tr.label, 8, y + tr.h / 2);
      y += tr.h + 4;
    }
    const words = u.words || [];
    const vis = u.visemes || [];
    const segs = expressionSegments(u.expressions, this.duration);
    this.drawWords(g, w, rows.words, words, u.syllables || []);
    this.drawVisemes(g, w, rows.visemes, vis);
    this.drawExpressions(g, w, rows.expressions, segs);
    this.drawMouth(g, w, rows.mouth);
    if (this.t !== null && this.t !== undefined) this.drawPlayhead(g, w, h);
    if (this.hover !== null && this.hover > GUTTER) this.drawHover(g, w, h, vis, words);

    this.drawn = {
      id: this.id,
      visemes: vis.length,
      expressions: segs.length,
      words: words.length,
      draws: this.drawn.draws + 1,
      playhead: this.t,
      duration: this.duration,
    };
  }

  /** The time axis: a tick and label every 0.25-2 s, depending on the duration. */
  drawAxis(g, w, h) {
    g.strokeStyle = '#343946';
    g.fillStyle = '#8b95a5';
    const step = this.duration > 12 ? 2 : this.duration > 5 ? 1 : this.duration > 2 ? 0.5 : 0.25;
    for (let t = 0; t <= this.duration + 1e-9; t += step) {
      const x = this.x(t, w);
      g.beginPath();
      g.moveTo(x + 0.5, AXIS - 4);
      g.lineTo(x + 0.5, h);
      g.stroke();
      g.fillText(`${Number(t.toFixed(2))}s`, x + 3, AXIS / 2);
    }
  }

  /** Words as boxes with their text, and a tick at each Chinese syllable. */
  drawWords(g, w, { y: ty, h: th }, words, syl) {
    for (const wd of words) {
      const x0 = this.x(wd.start, w);
      const x1 = this.x(wd.end, w);
      g.fillStyle = '#2c313c';
      g.fillRect(x0, ty, Math.max(1, x1 - x0 - 1), th);
      this.label(g, wd.text, x0 + 3, ty + th / 2, x1 - x0 - 5, '#e6e9ef');
    }
    for (const s of syl) {
      const x0 = this.x(s.start, w);
      g.fillStyle = '#4b5263';
      g.fillRect(x0, ty + th - 3, 1, 3);
    }
  }

  drawVisemes(g, w, { y: ty, h: th }, vis) {
    for (const v of vis) {
      const x0 = this.x(v.start, w);
      const x1 = this.x(v.end, w);
      g.fillStyle = visemeColor(v.viseme);
      g.fillRect(x0, ty, Math.max(1, x1 - x0 - 1), th);
      if (v.viseme !== 'sil') this.label(g, v.viseme, x0 + 2, ty + th / 2, x1 - x0 - 3, '#0f1115');
    }
  }

  /** Expressions: the level curve, coloured by the tag that drives it. */
  drawExpressions(g, w, { y: ty, h: th }, segs) {
    g.fillStyle = '#222631';
    g.fillRect(GUTTER, ty, w - GUTTER - 8, th);
    for (const sg of segs) {
      const x0 = this.x(sg.start, w);
      const x1 = this.x(Math.min(sg.end, this.duration), w);
      g.beginPath();
      g.moveTo(x0, ty + th);
      const n = Math.max(2, Math.ceil((x1 - x0) / 3));
      for (let i = 0; i <= n; i++) {
        const t = sg.start + ((Math.min(sg.end, this.duration) - sg.start) * i) / n;
        const v = sg.ramp > 0 ? sg.from + (sg.to - sg.from) * smooth((t - sg.start) / sg.ramp) : sg.to;
        g.lineTo(this.x(t, w), ty + th - v * (th - 2));
      }
      g.lineTo(x1, ty + th);
      g.closePath();
      g.fillStyle = expressionColor(sg.name);
      g.globalAlpha = 0.75;
      g.fill();
      g.globalAlpha = 1;
      g.fillStyle = '#ffffff';
      g.fillRect(x0, ty, 1, th);
      this.label(g, `${sg.name} ${Math.round(sg.to * 63)}`, x0 + 3, ty + 8, Math.max(40, x1 - x0 - 4), '#e6e9ef');
    }
    if (!segs.length) {
      g.fillStyle = '#6b7483';
      g.fillText('no expression tags', GUTTER + 6, ty + th / 2);
    }
  }

  /** The streamed jawOpen curve. */
  drawMouth(g, w, { y: ty, h: th }) {
    g.fillStyle = '#222631';
    g.fillRect(GUTTER, ty, w - GUTTER - 8, th);
    if (this.mouth.length > 1) {
      // Received frames: played (bright) and buffered ahead of the playhead (dim).
      const now = this.t ?? -Infinity;
      for (const played of [true, false]) {
        g.beginPath();
        let started = false;
        for (const [t, v] of this.mouth) {
          if (played ? t > now + 1e-6 : t < now - 1e-6) continue;
          const px = this.x(Math.min(t, this.duration), w);
          const py = ty + th - Math.max(0, Math.min(1, v)) * (th - 2);
          if (started) g.lineTo(px, py);
          else g.moveTo(px, py);
          started = true;
        }
        g.strokeStyle = played ? '#7fd1ae' : 'rgba(127, 209, 174, 0.35)';
        g.lineWidth = 1.5;
        g.stroke();
      }
      g.lineWidth = 1;
    } else if (this.t !== null && this.t > 0.3) {
      g.fillStyle = '#6b7483';
      g.fillText('the streamed jawOpen appears here in weights mode', GUTTER + 6, ty + th / 2);
    }
  }

  drawPlayhead(g, w, h) {
    const x = this.x(Math.max(0, Math.min(this.t, this.duration)), w);
    g.fillStyle = '#ff6b6b';
    g.fillRect(x - 1, AXIS - 4, 2, h - AXIS + 4);
    g.beginPath();
    g.moveTo(x - 5, AXIS - 6);
    g.lineTo(x + 5, AXIS - 6);
    g.lineTo(x, AXIS);
    g.fill();
  }

  /** The time, viseme and word under the mouse. */
  drawHover(g, w, h, vis, words) {
    const t = ((this.hover - GUTTER) / (w - GUTTER - 8)) * this.duration;
    const v = vis.find((e) => t >= e.start && t < e.end);
    const wd = words.find((e) => t >= e.start && t < e.end);
    const text = `${t.toFixed(2)} s${v ? `  ${v.viseme}` : ''}${wd ? `  “${wd.text}”` : ''}`;
    g.fillStyle = 'rgba(255,255,255,0.5)';
    g.fillRect(this.hover, AXIS, 1, h - AXIS);
    const tw = g.measureText(text).width + 10;
    const bx = Math.min(this.hover + 6, w - tw - 2);
    g.fillStyle = '#0f1115';
    g.fillRect(bx, h - 20, tw, 18);
    g.fillStyle = '#e6e9ef';
    g.fillText(text, bx + 5, h - 11);
  }

  label(g, text, x, y, maxW, color) {
    if (maxW < 8) return;
    g.save();
    g.beginPath();
    g.rect(x - 1, y - 10, maxW + 2, 20);
    g.clip();
    g.fillStyle = color;
    g.fillText(text, x, y);
    g.restore();
  }
}
