// Every request the extension's language client sends, to the real `latticesim lsp`, over
// the JSON-RPC library the client itself uses (vscode-jsonrpc): the server must announce
// each feature and answer each request as VS Code reads it. The program is $LATTICESIM, else
// the workspace's target/debug/latticesim.
// Run: node test/requests.test.js
"use strict";

const assert = require("assert");
const fs = require("fs");
const os = require("os");
const path = require("path");
const { spawn } = require("child_process");
const rpc = require("vscode-jsonrpc/node");

const program = process.env.LATTICESIM || path.join(__dirname, "../../../target/debug/latticesim");
const dir = fs.mkdtempSync(path.join(os.tmpdir(), "latticesim-vscode-"));
const rules = [
  "// walkers go east while C01 > 0,",
  "// until a resting agent is ahead",
  "walk",
  "1",
  "SWALK0 >C01 0000 !T1,0,REST*",
  "P1,0 C01 - C01 0001",
  "",
  "stop",
  "2",
  "SWALK0 =C01 0000",
  "SDONE0",
  "",
].join("\n");
const agents = "0,0 SWALK0 C01 3\n0,2 SWALK0 C01 1\n5,0 SREST0\n";
fs.writeFileSync(path.join(dir, "rules.txt"), rules);
fs.writeFileSync(path.join(dir, "agents.txt"), agents);
const rulesUri = "file://" + path.join(dir, "rules.txt");
const agentsUri = "file://" + path.join(dir, "agents.txt");

const child = spawn(program, ["lsp"], { stdio: ["pipe", "pipe", "inherit"] });
const conn = rpc.createMessageConnection(
  new rpc.StreamMessageReader(child.stdout),
  new rpc.StreamMessageWriter(child.stdin),
);
const diagnostics = {};
conn.onNotification("textDocument/publishDiagnostics", (p) => {
  diagnostics[p.uri] = p.diagnostics;
});
conn.listen();

const at = (uri, line, character) => ({ textDocument: { uri }, position: { line, character } });
const doc = { textDocument: { uri: rulesUri } };
const until = async (check) => {
  for (let i = 0; i < 200 && !check(); i++) await new Promise((r) => setTimeout(r, 25));
  assert.ok(check(), "the server published diagnostics");
};

(async () => {
  const init = await conn.sendRequest("initialize", {
    processId: process.pid,
    rootUri: null,
    capabilities: { textDocument: { rename: { prepareSupport: true } } },
  });
  const caps = init.capabilities;
  for (const c of [
    "hoverProvider",
    "completionProvider",
    "documentFormattingProvider",
    "codeActionProvider",
    "definitionProvider",
    "referencesProvider",
    "renameProvider",
    "documentSymbolProvider",
    "semanticTokensProvider",
    "foldingRangeProvider",
  ]) {
    assert.ok(caps[c], `the server announces ${c}`);
  }
  conn.sendNotification("initialized", {});
  for (const [uri, languageId, text] of [
    [rulesUri, "latticesim-rules", rules],
    [agentsUri, "latticesim-agents", agents],
  ]) {
    conn.sendNotification("textDocument/didOpen", { textDocument: { uri, languageId, version: 1, text } });
  }
  await until(() => diagnostics[rulesUri] && diagnostics[agentsUri]);
  assert.deepStrictEqual(diagnostics[rulesUri], []);

  const hover = await conn.sendRequest("textDocument/hover", at(rulesUri, 4, 1));
  assert.match(hover.contents.value, /state/i);
  const completion = await conn.sendRequest("textDocument/completion", at(rulesUri, 4, 0));
  assert.ok(completion.length > 5);

  const definition = await conn.sendRequest("textDocument/definition", at(rulesUri, 4, 1));
  assert.deepStrictEqual(
    definition.map((l) => [path.basename(l.uri), l.range.start.line]).sort(),
    [["agents.txt", 0], ["agents.txt", 1]],
  );
  const references = await conn.sendRequest("textDocument/references", {
    ...at(rulesUri, 4, 8),
    context: { includeDeclaration: true },
  });
  assert.strictEqual(references.length, 6, JSON.stringify(references));

  const prepared = await conn.sendRequest("textDocument/prepareRename", at(rulesUri, 4, 2));
  assert.strictEqual(prepared.placeholder, "WALK0");
  const edit = await conn.sendRequest("textDocument/rename", { ...at(rulesUri, 4, 2), newName: "STEP0" });
  assert.strictEqual(edit.changes[rulesUri].length, 2);
  assert.strictEqual(edit.changes[agentsUri].length, 2);
  await assert.rejects(
    conn.sendRequest("textDocument/rename", { ...at(agentsUri, 2, 6), newName: "WALL0" }),
    /`REST\*` \(rules.txt:5\) matches `REST0` but would not match `WALL0`/,
  );

  const symbols = await conn.sendRequest("textDocument/documentSymbol", doc);
  assert.deepStrictEqual(symbols.map((s) => s.name), ["walk", "stop"]);
  const tokens = await conn.sendRequest("textDocument/semanticTokens/full", doc);
  const legend = caps.semanticTokensProvider.legend.tokenTypes;
  assert.strictEqual(tokens.data.length % 5, 0);
  const kinds = new Set();
  for (let i = 0; i < tokens.data.length; i += 5) kinds.add(legend[tokens.data[i + 3]]);
  for (const k of ["comment", "function", "number", "keyword", "enumMember", "variable", "operator"]) {
    assert.ok(kinds.has(k), `a ${k} token`);
  }
  const folds = await conn.sendRequest("textDocument/foldingRange", doc);
  assert.deepStrictEqual(folds.map((f) => [f.startLine, f.endLine]), [[0, 1], [2, 5], [7, 10]]);
  const formatting = await conn.sendRequest("textDocument/formatting", {
    ...doc,
    options: { tabSize: 4, insertSpaces: true },
  });
  assert.ok(Array.isArray(formatting));
  const actions = await conn.sendRequest("textDocument/codeAction", {
    ...doc,
    range: { start: { line: 4, character: 0 }, end: { line: 4, character: 0 } },
    context: { diagnostics: [] },
  });
  assert.ok(Array.isArray(actions));

  await conn.sendRequest("shutdown");
  conn.sendNotification("exit");
  await new Promise((r) => child.on("exit", r));
  fs.rmSync(dir, { recursive: true, force: true });
  console.log("vscode extension: every request answered");
  process.exit(0);
})().catch((e) => {
  console.error(e);
  child.kill();
  process.exit(1);
});
