// The MDG extension: starts the `mdg-lsp` language server for .mdg files and adds
// "MDG: Preview", a live 3D view of the current file in a panel beside it
// (src/preview.ts), "MDG: Open in mdg-view", the external viewer window, and the
// commands of the server's code lenses (render, stats, guided search, creature
// evolution as tasks running mdg-run; the reference list of a rule).

import * as vscode from 'vscode';
import { spawn } from 'child_process';
import * as path from 'path';
import { LanguageClient, LanguageClientOptions, ServerOptions, TransportKind } from 'vscode-languageclient/node';
import { resolveProgram, runArgs, RunKind } from './paths';
import { PreviewPanel } from './preview';

let client: LanguageClient | undefined;
/** The extension's folder (a platform .vsix carries bin/mdg-lsp, bin/mdg-run, std/). */
let extensionPath: string | undefined;

export async function activate(context: vscode.ExtensionContext): Promise<void> {
  extensionPath = context.extensionPath;
  context.subscriptions.push(
    vscode.commands.registerCommand('mdg.preview', (uri?: string | vscode.Uri) => preview(context, uri)),
    vscode.commands.registerCommand('mdg.renderGlb', (uri?: string | vscode.Uri) => runTask('render', uri)),
    vscode.commands.registerCommand('mdg.stats', (uri?: string | vscode.Uri) => runTask('stats', uri)),
    vscode.commands.registerCommand('mdg.runSearch', (uri?: string | vscode.Uri) => runTask('search', uri)),
    vscode.commands.registerCommand('mdg.evolve', (uri?: string | vscode.Uri) => runTask('evolve', uri)),
    vscode.commands.registerCommand('mdg.showReferences', showReferences),
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

/** `mdg-run`: the setting, else the platform .vsix's own, else the one on PATH. */
function runProgram(): string {
  return resolveProgram('mdg-run', settings().get<string>('runPath'), extensionPath, workspaceRoot());
}

function workspaceRoot(): string | undefined {
  return vscode.workspace.workspaceFolders?.[0]?.uri.fsPath;
}

async function startClient(): Promise<void> {
  const command = resolveProgram('mdg-lsp', settings().get<string>('serverPath'), extensionPath, workspaceRoot());
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

/** How long a viewer that fails at once (no display, a bad file) is watched. */
const VIEWER_WATCH_MS = 2000;

/** Starts `command args` detached and watches it for its first two seconds: it is
 * missing, it failed then (its exit code and the end of its stderr), or it runs. */
function launchWatched(
  command: string,
  args: string[],
  cwd: string | undefined,
): Promise<{ kind: 'missing' } | { kind: 'failed'; code: number | null; stderr: string } | { kind: 'running' }> {
  return new Promise((resolve) => {
    const child = spawn(command, args, { cwd, detached: true, stdio: ['ignore', 'ignore', 'pipe'] });
    let stderr = '';
    let done = false;
    const finish = (v: { kind: 'missing' } | { kind: 'failed'; code: number | null; stderr: string } | { kind: 'running' }) => {
      if (done) return;
      done = true;
      clearTimeout(timer);
      // The pipe stays read (and dropped): a viewer writing to a closed stderr would fail.
      child.unref();
      resolve(v);
    };
    const timer = setTimeout(() => finish({ kind: 'running' }), VIEWER_WATCH_MS);
    child.stderr?.on('data', (d: Buffer) => (stderr = (stderr + d.toString()).slice(-4000)));
    child.once('error', (e: NodeJS.ErrnoException) => finish(e.code === 'ENOENT' ? { kind: 'missing' } : { kind: 'failed', code: null, stderr: e.message }));
    child.once('exit', (code) => finish(code === 0 ? { kind: 'running' } : { kind: 'failed', code, stderr }));
  });
}

/** The .mdg document a command names (a code lens passes its URI), else the active
 * editor's; or an error shown (not awaited) and undefined. */
async function targetMdg(uri?: string | vscode.Uri): Promise<vscode.TextDocument | undefined> {
  // The editor title menu passes the file's Uri, a lens the URI string.
  const target = uri instanceof vscode.Uri ? uri : typeof uri === 'string' && uri !== '' ? vscode.Uri.parse(uri) : undefined;
  if (target) {
    try {
      return await vscode.workspace.openTextDocument(target);
    } catch (e) {
      void vscode.window.showErrorMessage(`MDG: cannot open ${uri}: ${e}`);
      return undefined;
    }
  }
  return activeMdg();
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
async function preview(context: vscode.ExtensionContext, uri?: string | vscode.Uri): Promise<void> {
  const doc = await targetMdg(uri);
  if (doc) {
    PreviewPanel.show(context, doc, runProgram, () => client);
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
  // A window needs a display where the extension host runs (a remote one,
  // code-server or SSH, often has none): say so rather than fail silently.
  if (process.platform === 'linux' && !process.env.DISPLAY && !process.env.WAYLAND_DISPLAY) {
    void vscode.window.showErrorMessage(
      'MDG: mdg-view opens a window, and there is no display here (neither DISPLAY nor WAYLAND_DISPLAY is set, as in a remote window). Use MDG: Preview, which draws inside VS Code.',
    );
    return;
  }
  const early = await launchWatched(viewer, [doc.uri.fsPath], cwd);
  if (early.kind === 'failed') {
    void vscode.window.showErrorMessage(`MDG: mdg-view exited with ${early.code}: ${early.stderr.trim().split('\n').slice(-3).join(' ') || '(no message)'}`);
    return;
  }
  if (early.kind === 'missing') {
    void vscode.window.showErrorMessage(`MDG: \`${viewer}\` was not found; set "mdg.viewerPath" (or use MDG: Preview, which needs only mdg-run).`);
  }
}

const TASK_NAMES: Record<RunKind, string> = { render: 'Render .glb', stats: 'Stats', search: 'Run search', evolve: 'Evolve' };

/** A code lens's run: `mdg-run` on the saved file as a task, its output in the terminal panel. */
async function runTask(kind: RunKind, uri?: string | vscode.Uri): Promise<void> {
  const doc = await targetMdg(uri);
  if (!doc) {
    return;
  }
  if (doc.isUntitled) {
    void vscode.window.showErrorMessage(`MDG: save the file before ${TASK_NAMES[kind]}.`);
    return;
  }
  if (doc.isDirty) {
    await doc.save();
  }
  const file = doc.uri.fsPath;
  const run = runProgram();
  const folder = vscode.workspace.getWorkspaceFolder(doc.uri);
  const execution = new vscode.ProcessExecution(run, runArgs(kind, file), { cwd: path.dirname(file) });
  const task = new vscode.Task(
    { type: 'mdg', command: kind, file },
    folder ?? vscode.TaskScope.Workspace,
    `${TASK_NAMES[kind]}: ${path.basename(file)}`,
    'mdg',
    execution,
  );
  task.presentationOptions = { reveal: vscode.TaskRevealKind.Always, clear: true };
  try {
    await vscode.tasks.executeTask(task);
  } catch (e) {
    void vscode.window.showErrorMessage(`MDG: cannot run \`${run}\` (${e}); set "mdg.runPath".`);
  }
}

interface LspPosition {
  line: number;
  character: number;
}

interface LspLocation {
  uri: string;
  range: { start: LspPosition; end: LspPosition };
}

/** A rule's reference lens: the server's locations in the references peek view. */
async function showReferences(uri: string, position: LspPosition, locations: LspLocation[]): Promise<void> {
  const pos = (p: LspPosition) => new vscode.Position(p.line, p.character);
  const locs = (locations ?? []).map((l) => new vscode.Location(vscode.Uri.parse(l.uri), new vscode.Range(pos(l.range.start), pos(l.range.end))));
  await vscode.commands.executeCommand('editor.action.showReferences', vscode.Uri.parse(uri), pos(position), locs);
}
