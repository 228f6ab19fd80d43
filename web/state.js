// What the page's modules share: the run being shown (the player's state) and the
// agents selected in it. A leaf: it imports nothing, so that the modules that draw, step
// and inspect can all read it without importing each other.

export const player = {
  frame: null,       // the configuration shown (see Frame in src/serve.rs)
  running: false,
  runGen: 0,         // the generation of the one run loop that may go on
  target: null,      // step asked for while a request is under way
  busy: false,       // a jump (gotoStep) is under way
  idle: null,        // resolved when that jump is done
  session: null,
  editing: false,    // clicks edit the agents (edit.js)
};

// The marks of agents, drawn over their colours: a highlighted state's agents in white
// ringed with black (the palette keeps away from white: no state is drawn so), the
// inspected agent in blue ringed with white.
export const MARKS = { highlight: ['#000000', '#ffffff'], selected: ['#ffffff', '#0050ff'] };

export const selection = {
  selected: null,    // the inspected agent id
  highlight: new Set(),
  activeRecord: -1,
  // Per state name, what the legend made of it: { colour: '#rrggbb' } chosen in the page,
  // { mode: 'highlight' | 'hidden' }.
  looks: new Map(),
  looksVersion: 0,   // changed with every change of looks (drawings cached per frame see it)
  colourBy: null,    // a counter ('C00') to colour the agents by, instead of their state
};

// The scale of a counter: viridis, as `latticesim render --color-by` draws it.
const SCALE = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];
export function scaleColour(t) {
  const x = Math.max(0, Math.min(1, t)) * (SCALE.length - 1);
  const i = Math.min(Math.floor(x), SCALE.length - 2), k = x - i;
  const c = SCALE[i].map((a, j) => Math.round(a + (SCALE[i + 1][j] - a) * k));
  return '#' + ((1 << 24) | (c[0] << 16) | (c[1] << 8) | c[2]).toString(16).slice(1);
}

// The smallest and largest value of the counter a frame carries.
export function valueRange(f) {
  if (!f.values) return null;
  if (!f.range) {
    let lo = Infinity, hi = -Infinity;
    for (const v of f.values) { if (v < lo) lo = v; if (v > hi) hi = v; }
    f.range = f.values.length ? [lo, hi] : [0, 0];
  }
  return f.range;
}

// The colour agent `i` of frame `f` is drawn in: its state's (see stateColours, given as
// `colours`), or its counter's on the scale when colouring by a counter; null when its
// state is hidden.
export function agentColour(f, colours, i) {
  const c = colours[f.state[i]];
  if (c === null || !selection.colourBy || !f.values) return c;
  const [lo, hi] = valueRange(f);
  return scaleColour(hi > lo ? (f.values[i] - lo) / (hi - lo) : 0.5);
}

// A colour faded towards white (the states not highlighted while one is).
function fade(hex) {
  const v = parseInt(hex.slice(1), 16);
  const mix = (c) => Math.round(c + (255 - c) * 0.75);
  const [r, g, b] = [mix(v >> 16), mix((v >> 8) & 255), mix(v & 255)];
  return '#' + ((1 << 24) | (r << 16) | (g << 8) | b).toString(16).slice(1);
}

// The colour each state of frame `f` is drawn in: the one chosen in the page, else the
// run's; faded when another state is highlighted; null for a hidden state (neither
// drawn nor picked).
export function stateColours(f) {
  const any = [...selection.looks.values()].some((l) => l.mode === 'highlight');
  return f.states.map((st) => {
    const l = selection.looks.get(st.name) || {};
    if (l.mode === 'hidden') return null;
    const c = l.colour || st.colour;
    return any && l.mode !== 'highlight' ? fade(c) : c;
  });
}
