// The extension without VS Code: `vscode` and `vscode-languageclient` are stood in for, and
// activation must start `latticesim lsp` (or the program `latticesim.path` names) for the
// two languages the server knows; the manifest and grammars must read. Run: node test/activate.test.js
"use strict";

const assert = require("assert");
const fs = require("fs");
const path = require("path");
const Module = require("module");

const root = path.join(__dirname, "..");
let started = [];
let stopped = 0;
let configured = {};

const fakes = {
  vscode: {
    workspace: { getConfiguration: () => ({ get: (k) => configured[k] }) },
  },
  "vscode-languageclient/node": {
    LanguageClient: class {
      constructor(id, name, server, client) {
        Object.assign(this, { id, name, server, client });
      }
      start() {
        started.push(this);
        return Promise.resolve();
      }
      stop() {
        stopped += 1;
        return Promise.resolve();
      }
    },
  },
};
const load = Module._load;
Module._load = function (request, parent, isMain) {
  if (request in fakes) return fakes[request];
  return load.call(this, request, parent, isMain);
};

const ext = require(path.join(root, "extension.js"));
const manifest = JSON.parse(fs.readFileSync(path.join(root, "package.json"), "utf8"));

(async () => {
  // Activation starts the server for both languages.
  const context = { subscriptions: [] };
  await ext.activate(context);
  assert.strictEqual(started.length, 1);
  const c = started[0];
  assert.deepStrictEqual(c.server, { command: "latticesim", args: ["lsp"] });
  const langs = c.client.documentSelector.map((s) => s.language).sort();
  assert.deepStrictEqual(langs, ["latticesim-agents", "latticesim-rules"]);
  await ext.deactivate();
  assert.strictEqual(stopped, 1);

  // `latticesim.path` names the program.
  configured = { path: "/opt/latticesim/bin/latticesim" };
  assert.strictEqual(ext.serverOptions({ get: (k) => configured[k] }).command, "/opt/latticesim/bin/latticesim");

  // The manifest's languages are the server's, and each has a grammar that reads.
  const ids = manifest.contributes.languages.map((l) => l.id).sort();
  assert.deepStrictEqual(ids, langs);
  const server = fs.readFileSync(path.join(root, "../../src/lsp/mod.rs"), "utf8");
  for (const id of ids) assert.ok(server.includes(`"${id}"`), `the server knows ${id}`);
  for (const g of manifest.contributes.grammars) {
    const grammar = JSON.parse(fs.readFileSync(path.join(root, g.path), "utf8"));
    assert.strictEqual(grammar.scopeName, g.scopeName);
    for (const p of grammar.patterns) new RegExp(p.match);
  }
  JSON.parse(fs.readFileSync(path.join(root, "language-configuration.json"), "utf8"));
  console.log("vscode extension: all passed");
})().catch((e) => {
  console.error(e);
  process.exit(1);
});
