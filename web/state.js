// What the page's modules share: the run being shown (the player's state) and the
// agents selected in it. A leaf: it imports nothing, so that the modules that draw, step
// and inspect can all read it without importing each other.

export const player = {
  frame: null,       // the configuration shown (see Frame in src/serve.rs)
  running: false,
  runGen: 0,         // the generation of the one run loop that may go on
  target: null,      // step asked for while a request is under way
  busy: false,
  session: null,
};

export const selection = {
  selected: null,    // the inspected agent id
  highlight: new Set(),
  activeRecord: -1,
  // Per state name, what the legend made of it: { colour: '#rrggbb' } chosen in the page,
  // { mode: 'highlight' | 'hidden' }.
  looks: new Map(),
  looksVersion: 0,   // changed with every change of looks (drawings cached per frame see it)
};

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
