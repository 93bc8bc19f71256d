// The MDG extension: starts the `mdg-lsp` language server for .mdg files and adds
// "MDG: Preview", which opens the current file in `mdg-view` (or, without the
// viewer, renders it with `mdg-run --png` and opens the picture).

import * as vscode from 'vscode';
import * as fs from 'fs';
import { spawn } from 'child_process';
import { LanguageClient, LanguageClientOptions, ServerOptions, TransportKind } from 'vscode-languageclient/node';
import { previewOutputs, resolveServerPath, runArgs } from './paths';

let client: LanguageClient | undefined;

export async function activate(context: vscode.ExtensionContext): Promise<void> {
  context.subscriptions.push(
    vscode.commands.registerCommand('mdg.preview', preview),
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
    const choice = await vscode.window.showErrorMessage(
      `MDG: cannot start the language server \`${command}\` (${e}). Install mdg-lsp or set "mdg.serverPath".`,
      'Open Settings',
    );
    if (choice === 'Open Settings') {
      await vscode.commands.executeCommand('workbench.action.openSettings', 'mdg.serverPath');
    }
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

/** Runs `command args` to completion; resolves with its exit code and stderr. */
function run(command: string, args: string[], cwd: string | undefined): Promise<{ code: number | null; stderr: string; missing: boolean }> {
  return new Promise((resolve) => {
    const child = spawn(command, args, { cwd, stdio: ['ignore', 'ignore', 'pipe'] });
    let stderr = '';
    child.stderr?.on('data', (d: Buffer) => (stderr += d.toString()));
    child.once('error', (e: NodeJS.ErrnoException) => resolve({ code: null, stderr: e.message, missing: e.code === 'ENOENT' }));
    child.once('close', (code) => resolve({ code, stderr, missing: false }));
  });
}

async function preview(): Promise<void> {
  const editor = vscode.window.activeTextEditor;
  if (!editor || editor.document.languageId !== 'mdg') {
    await vscode.window.showErrorMessage('MDG: Preview needs an open .mdg file.');
    return;
  }
  const doc = editor.document;
  if (doc.isUntitled) {
    await vscode.window.showErrorMessage('MDG: save the file before previewing it.');
    return;
  }
  if (doc.isDirty) {
    await doc.save();
  }
  const file = doc.uri.fsPath;
  const cwd = vscode.workspace.getWorkspaceFolder(doc.uri)?.uri.fsPath;
  if (await launch(settings().get<string>('viewerPath', 'mdg-view'), [file], cwd)) {
    return;
  }
  // No viewer: render a picture with mdg-run and show it beside the source.
  const outputs = previewOutputs(file);
  fs.mkdirSync(outputs.dir, { recursive: true });
  const runner = settings().get<string>('runPath', 'mdg-run');
  const result = await vscode.window.withProgress(
    { location: vscode.ProgressLocation.Notification, title: 'MDG: rendering a preview…' },
    () => run(runner, runArgs(file, outputs), cwd),
  );
  if (result.missing) {
    await vscode.window.showErrorMessage('MDG: neither mdg-view nor mdg-run was found; set "mdg.viewerPath" or "mdg.runPath".');
    return;
  }
  if (result.code !== 0) {
    await vscode.window.showErrorMessage(`MDG: mdg-run failed: ${result.stderr.trim().split('\n').slice(0, 5).join(' ')}`);
    return;
  }
  await vscode.commands.executeCommand('vscode.open', vscode.Uri.file(outputs.png), {
    viewColumn: vscode.ViewColumn.Beside,
    preview: true,
  });
}
