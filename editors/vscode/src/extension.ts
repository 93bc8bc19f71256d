// The MDG extension: starts the `mdg-lsp` language server for .mdg files and adds
// "MDG: Preview", a live 3D view of the current file in a panel beside it
// (src/preview.ts), and "MDG: Open in mdg-view", the external viewer window.

import * as vscode from 'vscode';
import { spawn } from 'child_process';
import { LanguageClient, LanguageClientOptions, ServerOptions, TransportKind } from 'vscode-languageclient/node';
import { resolveServerPath } from './paths';
import { PreviewPanel } from './preview';

let client: LanguageClient | undefined;

export async function activate(context: vscode.ExtensionContext): Promise<void> {
  context.subscriptions.push(
    vscode.commands.registerCommand('mdg.preview', () => preview(context)),
    vscode.commands.registerCommand('mdg.openInViewer', openInViewer),
    vscode.commands.registerCommand('mdg.restartServer', restart),
    vscode.workspace.onDidChangeConfiguration(async (e) => {
      if (e.affectsConfiguration('mdg.serverPath') || e.affectsConfiguration('mdg.stdPath')) {
        await restart();
      }
    }),
  );
  await startClient();
}

export async function deactivate(): Promise<void> {
  await stopClient();
}

function settings(): vscode.WorkspaceConfiguration {
  return vscode.workspace.getConfiguration('mdg');
}

function workspaceRoot(): string | undefined {
  return vscode.workspace.workspaceFolders?.[0]?.uri.fsPath;
}

async function startClient(): Promise<void> {
  const command = resolveServerPath(settings().get<string>('serverPath'), workspaceRoot());
  const env: NodeJS.ProcessEnv = { ...process.env };
  const std = settings().get<string>('stdPath', '').trim();
  if (std !== '') {
    env.MDG_STD = std;
  }
  const serverOptions: ServerOptions = { command, transport: TransportKind.stdio, options: { env } };
  const clientOptions: LanguageClientOptions = {
    documentSelector: [
      { scheme: 'file', language: 'mdg' },
      { scheme: 'untitled', language: 'mdg' },
    ],
    outputChannelName: 'MDG',
  };
  client = new LanguageClient('mdg', 'MDG Language Server', serverOptions, clientOptions);
  try {
    await client.start();
  } catch (e) {
    client = undefined;
    // Not awaited: the notification stays up without blocking every command.
    void vscode.window
      .showErrorMessage(
        `MDG: cannot start the language server \`${command}\` (${e}). Install mdg-lsp or set "mdg.serverPath".`,
        'Open Settings',
      )
      .then((choice) => {
        if (choice === 'Open Settings') {
          void vscode.commands.executeCommand('workbench.action.openSettings', 'mdg.serverPath');
        }
      });
  }
}

async function stopClient(): Promise<void> {
  const c = client;
  client = undefined;
  if (c) {
    await c.stop();
  }
}

async function restart(): Promise<void> {
  await stopClient();
  await startClient();
}

/** Starts `command args` detached; false if the program does not exist. */
function launch(command: string, args: string[], cwd: string | undefined): Promise<boolean> {
  return new Promise((resolve) => {
    const child = spawn(command, args, { cwd, detached: true, stdio: 'ignore' });
    child.once('error', () => resolve(false));
    child.once('spawn', () => {
      child.unref();
      resolve(true);
    });
  });
}

/** The .mdg file of the active editor, or an error shown (not awaited) and undefined. */
function activeMdg(): vscode.TextDocument | undefined {
  const editor = vscode.window.activeTextEditor;
  if (!editor || editor.document.languageId !== 'mdg') {
    void vscode.window.showErrorMessage('MDG: Preview needs an open .mdg file.');
    return undefined;
  }
  return editor.document;
}

/** "MDG: Preview": the live 3D panel. */
function preview(context: vscode.ExtensionContext): void {
  const doc = activeMdg();
  if (doc) {
    PreviewPanel.show(context, doc, () => settings().get<string>('runPath', 'mdg-run'));
  }
}

/** "MDG: Open in mdg-view": the saved file in the external viewer window. */
async function openInViewer(): Promise<void> {
  const doc = activeMdg();
  if (!doc) {
    return;
  }
  if (doc.isUntitled) {
    void vscode.window.showErrorMessage('MDG: save the file before opening it in mdg-view.');
    return;
  }
  if (doc.isDirty) {
    await doc.save();
  }
  const cwd = vscode.workspace.getWorkspaceFolder(doc.uri)?.uri.fsPath;
  const viewer = settings().get<string>('viewerPath', 'mdg-view');
  if (!(await launch(viewer, [doc.uri.fsPath], cwd))) {
    void vscode.window.showErrorMessage(`MDG: \`${viewer}\` was not found; set "mdg.viewerPath" (or use MDG: Preview, which needs only mdg-run).`);
  }
}
