// The latticesim extension: starts `latticesim lsp` for rules and agents files. Everything
// else (diagnostics, hover, completion, formatting, quick fixes, definition, references,
// rename, symbols, semantic tokens, folding) is the server's, which the language client
// asks for as the server announces it.
"use strict";

const vscode = require("vscode");
const { LanguageClient } = require("vscode-languageclient/node");

let client;

/** The options the server is started with: `latticesim lsp`, `latticesim.path` naming the program. */
function serverOptions(config) {
  const command = config.get("path") || "latticesim";
  return { command, args: ["lsp"] };
}

/** The documents the client serves: rules and agents files, on disk or not yet saved. */
const documentSelector = [
  { language: "latticesim-rules" },
  { language: "latticesim-agents" },
];

function activate(context) {
  const config = vscode.workspace.getConfiguration("latticesim");
  client = new LanguageClient(
    "latticesim",
    "latticesim",
    serverOptions(config),
    { documentSelector },
  );
  context.subscriptions.push({ dispose: () => client && client.stop() });
  return client.start();
}

function deactivate() {
  return client ? client.stop() : undefined;
}

module.exports = { activate, deactivate, serverOptions, documentSelector };
