// What the page's modules share: the run being shown (the player's state) and the
// agents selected in it. A leaf: it imports nothing, so that the modules that draw, step
// and inspect can all read it without importing each other.

export const player = {
  frame: null,       // the configuration shown (see Frame in src/serve.rs)
  running: false,
  target: null,      // step asked for while a request is under way
  busy: false,
  session: null,
};

export const selection = {
  selected: null,    // the inspected agent id
  highlight: new Set(),
  activeRecord: -1,
};
