// The MCL extension's client: starts the language server (`mcl lsp`, over stdio) for .mcl and
// .tasks files. The colours come from the TextMate grammars in syntaxes/, with no server.
"use strict";

const vscode = require("vscode");
const { LanguageClient, TransportKind } = require("vscode-languageclient/node");

let client;

function activate(context) {
  const config = vscode.workspace.getConfiguration("mcl");
  const [command, ...args] = config.get("server.command", ["mcl", "lsp"]);
  const serverOptions = { command, args, transport: TransportKind.stdio };
  const clientOptions = {
    documentSelector: [
      { scheme: "file", language: "mcl" },
      { scheme: "file", language: "mcl-tasks" },
      { scheme: "untitled", language: "mcl" },
    ],
    synchronize: { fileEvents: vscode.workspace.createFileSystemWatcher("**/*.{mcl,tasks}") },
  };
  client = new LanguageClient("mcl", "MCL language server", serverOptions, clientOptions);
  client.start().catch((error) => {
    vscode.window.showErrorMessage(
      `MCL: could not start the language server (${command} ${args.join(" ")}): ${error}. ` +
        "Set mcl.server.command to the mcl of your environment.");
  });
  context.subscriptions.push({ dispose: () => client && client.stop() });
}

function deactivate() {
  return client ? client.stop() : undefined;
}

module.exports = { activate, deactivate };
