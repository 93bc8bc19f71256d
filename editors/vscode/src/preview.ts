// "MDG: Preview": a live 3D view of the current file in a webview beside it. The
// language server evaluates the editor's text (the `mdg/preview` request: the
// server is already running and holds the text, so there is no process to start
// and no file to write) when the panel opens, on save, and after each edit, as
// soon as the last evaluation's time has passed without another key
// (`adaptiveDebounce`); a newer edit stops the run in progress. The model comes
// back as a binary glTF that the webview (webview/preview.js, three.js) shows,
// keeping the camera. Errors (the compiler's diagnostics) and limit warnings are
// shown in the panel. Each `@param` gets a slider; the seed field and the
// variation keys choose the seed. Grammars with a `search`, `creature` or `grid`
// section, or no server, are evaluated with `mdg-run FILE --stdin -o X.glb`.

import * as vscode from 'vscode';
import * as fs from 'fs';
import * as crypto from 'crypto';
import * as path from 'path';
import { spawn } from 'child_process';
import type { LanguageClient } from 'vscode-languageclient/node';
import { adaptiveDebounce, keptValues, ParamDecl, previewArgs, previewGlb, randseedEdit, ruleHeaderLine, siteCandidates, sliderRange, stepSeed } from './paths';

/** `mdg/preview`'s answer (lsp/src/preview.rs). */
interface PreviewAnswer {
  status: 'model' | 'error' | 'cancelled' | 'mode';
  version: number;
  seed: string;
  glb: string;
  warnings: string[];
  message: string;
  params: ParamDecl[] | null;
  /** The derivation inspector's tree (lsp/src/preview.rs; vm Derivation). */
  tree: unknown;
  stats: { compileMs: number; evalMs: number; exportMs: number; bytes: number; ruleCalls: number; vertices: number; triangles: number };
}
/** The cursor's rule is looked up this long after it stops moving. */
const HIGHLIGHT_DEBOUNCE_MS = 80;
/** A slider re-evaluates this long after it stops moving. */
const SLIDER_DEBOUNCE_MS = 250;

/** Runs `command args` with `input` on stdin; its exit code and stderr. */
function runWithInput(command: string, args: string[], cwd: string | undefined, input: string): Promise<{ code: number | null; stderr: string; missing: boolean }> {
  return new Promise((resolve) => {
    const child = spawn(command, args, { cwd, stdio: ['pipe', 'ignore', 'pipe'] });
    let stderr = '';
    child.stderr?.on('data', (d: Buffer) => (stderr += d.toString()));
    child.once('error', (e: NodeJS.ErrnoException) => resolve({ code: null, stderr: e.message, missing: e.code === 'ENOENT' }));
    child.once('close', (code) => resolve({ code, stderr, missing: false }));
    child.stdin?.on('error', () => {});
    child.stdin?.end(input);
  });
}

export class PreviewPanel {
  private static panels = new Map<string, PreviewPanel>();
  private readonly disposables: vscode.Disposable[] = [];
  private timer: NodeJS.Timeout | undefined;
  private highlightTimer: NodeJS.Timeout | undefined;
  private running = false;
  private again = false;
  /** Bumped by every evaluation asked of the server: an older answer is dropped. */
  private generation = 0;
  /** How long the server worked on the last evaluation (ms): the debounce. */
  private lastMs: number | undefined;
  /** When the first edit not yet shown was made (ms since the epoch), for the panel's latency. */
  private editAt: number | undefined;
  /** The seed asked for (decimal); undefined: the grammar's `randseed`. */
  private seed: string | undefined;
  /** The seed of the model shown. */
  private shownSeed: string | undefined;
  /** The last message posted, for tests and the status. */
  lastTriangles = -1;
  /** The `@param`s of the last compile (from `mdg-run --params-json`). */
  private declared: ParamDecl[] = [];
  /** The values the sliders were moved to, by name (passed as `--param`). */
  private values: Record<string, number> = {};

  /** Opens (or reveals) the preview of `doc`. */
  static show(
    context: vscode.ExtensionContext,
    doc: vscode.TextDocument,
    runPath: () => string,
    client: () => LanguageClient | undefined,
  ): PreviewPanel {
    const key = doc.uri.toString();
    const existing = PreviewPanel.panels.get(key);
    if (existing) {
      existing.panel.reveal(vscode.ViewColumn.Beside, true);
      existing.evaluate();
      return existing;
    }
    const p = new PreviewPanel(context, doc, runPath, client);
    PreviewPanel.panels.set(key, p);
    return p;
  }

  private readonly panel: vscode.WebviewPanel;

  private constructor(
    private readonly context: vscode.ExtensionContext,
    private readonly doc: vscode.TextDocument,
    private readonly runPath: () => string,
    private readonly client: () => LanguageClient | undefined,
  ) {
    const media = vscode.Uri.joinPath(context.extensionUri, 'out', 'webview');
    this.panel = vscode.window.createWebviewPanel(
      'mdg.preview',
      `Preview ${doc.uri.path.split('/').pop()}`,
      { viewColumn: vscode.ViewColumn.Beside, preserveFocus: true },
      { enableScripts: true, retainContextWhenHidden: true, localResourceRoots: [media] },
    );
    this.panel.webview.html = this.html(this.panel.webview.asWebviewUri(vscode.Uri.joinPath(media, 'preview.js')));
    this.disposables.push(
      this.panel.webview.onDidReceiveMessage((m) => {
        if (m?.type === 'ready') {
          this.evaluate();
        } else if (m?.type === 'shown') {
          this.lastTriangles = m.triangles;
        } else if (m?.type === 'site' && typeof m.file === 'string' && typeof m.line === 'number') {
          void this.reveal(m.file, m.line, typeof m.rule === 'string' ? m.rule : '', m.definition === true);
        } else if (m?.type === 'param' && typeof m.name === 'string' && typeof m.value === 'number') {
          this.values[m.name] = m.value;
          clearTimeout(this.timer);
          this.timer = setTimeout(() => this.evaluate(), SLIDER_DEBOUNCE_MS);
        } else if (m?.type === 'seed' && typeof m.seed === 'string') {
          this.setSeed(m.seed);
        } else if (m?.type === 'variation' && typeof m.delta === 'number') {
          const next = stepSeed(this.shownSeed ?? this.seed ?? '0', m.delta);
          if (next !== undefined) this.setSeed(next);
        } else if (m?.type === 'keep') {
          void this.keep();
        } else if (m?.type === 'sheet') {
          void this.sheet();
        }
      }),
      vscode.workspace.onDidSaveTextDocument((d) => {
        if (d === this.doc) {
          this.evaluate();
        }
      }),
      vscode.workspace.onDidChangeTextDocument((e) => {
        if (e.document === this.doc && e.contentChanges.length > 0) {
          this.editAt ??= Date.now();
          clearTimeout(this.timer);
          this.timer = setTimeout(() => this.evaluate(), adaptiveDebounce(this.lastMs));
        }
      }),
      // Cursor → geometry: the rule under the cursor lights up in the preview.
      vscode.window.onDidChangeTextEditorSelection((e) => {
        if (e.textEditor.document === this.doc) {
          clearTimeout(this.highlightTimer);
          this.highlightTimer = setTimeout(() => void this.highlightAt(e.textEditor.selection.active), HIGHLIGHT_DEBOUNCE_MS);
        }
      }),
      vscode.workspace.onDidCloseTextDocument((d) => {
        if (d === this.doc) {
          this.panel.dispose();
        }
      }),
    );
    this.panel.onDidDispose(() => this.dispose(), null, this.disposables);
  }

  /** Shows the line a click on the model (or on a row of the inspector: `definition`,
   * the rule's `rule NAME` line at or above it) named, in the editor beside the panel. */
  private async reveal(file: string, line: number, rule: string, definition = false): Promise<void> {
    const std = vscode.workspace.getConfiguration('mdg').get<string>('stdPath', '').trim();
    const stdDirs = [std, path.join(this.context.extensionPath, 'std')];
    const root = vscode.workspace.getWorkspaceFolder(this.doc.uri)?.uri.fsPath;
    if (root) stdDirs.push(path.join(root, 'std'));
    const found = siteCandidates(file, this.doc.uri.fsPath, stdDirs.filter((d) => d !== '')).find((f) => fs.existsSync(f));
    if (!found) {
      void vscode.window.showInformationMessage(`MDG: drawn by rule ${rule} at ${file}:${line} (file not found)`);
      return;
    }
    const column = vscode.window.visibleTextEditors.find((e) => e.document === this.doc)?.viewColumn ?? vscode.ViewColumn.One;
    const editor = await vscode.window.showTextDocument(vscode.Uri.file(found), { viewColumn: column, preserveFocus: false });
    let at = Math.min(Math.max(line - 1, 0), editor.document.lineCount - 1);
    if (definition) {
      at = ruleHeaderLine((i) => editor.document.lineAt(i).text, at, rule);
    }
    const pos = new vscode.Position(at, 0);
    editor.selection = new vscode.Selection(pos, editor.document.lineAt(pos.line).range.end);
    editor.revealRange(editor.selection, vscode.TextEditorRevealType.InCenterIfOutsideViewport);
  }

  /**
   * What the cursor at `pos` names, for the preview to light up: on a rule's name
   * (a call or a definition), the triangles that rule's own ops drew wherever it is
   * defined; elsewhere inside a rule definition, those its ops on those lines drew.
   */
  private async highlightAt(pos: vscode.Position): Promise<void> {
    const word = this.doc.getWordRangeAtPosition(pos, /[A-Za-z_][A-Za-z0-9_.]*/);
    const name = word ? this.doc.getText(word) : '';
    let range: vscode.Range | undefined;
    try {
      const symbols = (await vscode.commands.executeCommand<vscode.DocumentSymbol[]>('vscode.executeDocumentSymbolProvider', this.doc.uri)) ?? [];
      const within: vscode.DocumentSymbol[] = [];
      const walk = (list: vscode.DocumentSymbol[]) => {
        for (const sym of list) {
          if (sym.range.contains(pos)) within.push(sym);
          walk(sym.children ?? []);
        }
      };
      walk(symbols);
      // The innermost: one definition of a rule, not the group of its definitions.
      within.sort((a, b) => a.range.end.line - a.range.start.line - (b.range.end.line - b.range.start.line));
      range = within[0]?.range;
    } catch {
      range = undefined;
    }
    void this.panel.webview.postMessage({
      type: 'highlight',
      rule: name,
      file: path.basename(this.doc.uri.fsPath),
      from: range ? range.start.line + 1 : 0,
      to: range ? range.end.line + 1 : -1,
    });
  }

  private dispose(): void {
    clearTimeout(this.timer);
    clearTimeout(this.highlightTimer);
    PreviewPanel.panels.delete(this.doc.uri.toString());
    for (const d of this.disposables.splice(0)) {
      d.dispose();
    }
  }

  /** Evaluates the current text: in the language server, else with `mdg-run`. */
  async evaluate(): Promise<void> {
    const client = this.client();
    if (client?.isRunning()) {
      return this.evaluateInServer(client);
    }
    return this.evaluateWithRun();
  }

  /** A seed typed in the panel or stepped to ('' = the grammar's own). */
  private setSeed(seed: string): void {
    const s = seed.trim();
    if (s !== '' && stepSeed(s, 0) === undefined) {
      void this.panel.webview.postMessage({ type: 'error', message: `seed \`${s}\`: expected a whole number from 0 to 18446744073709551615` });
      return;
    }
    this.seed = s === '' ? undefined : s;
    clearTimeout(this.timer);
    void this.evaluate();
  }

  /** "Keep this variation": the seed shown becomes the grammar's `randseed`, and the
   * `mdg-run --seed` command that makes the same model goes to the clipboard. */
  private async keep(): Promise<void> {
    const seed = this.shownSeed;
    if (seed === undefined) return;
    const edit = randseedEdit(this.doc.getText(), seed);
    const we = new vscode.WorkspaceEdit();
    if (edit.replace) {
      we.replace(this.doc.uri, this.doc.lineAt(edit.line).range, edit.text);
    } else {
      we.insert(this.doc.uri, new vscode.Position(Math.min(edit.line, this.doc.lineCount), 0), `${edit.text}\n`);
    }
    await vscode.workspace.applyEdit(we);
    // The grammar's own seed is now this one.
    this.seed = undefined;
    const command = `mdg-run ${path.basename(this.doc.uri.fsPath)} --seed ${seed}`;
    let copied = true;
    try {
      await vscode.env.clipboard.writeText(command);
    } catch {
      copied = false;
    }
    const where = copied ? 'is on the clipboard' : 'makes the same model (the clipboard could not be written)';
    // In the status bar, not a notification: a toast would cover the panel's bar.
    vscode.window.setStatusBarMessage(`MDG: kept seed ${seed}: randseed ${seed} is in the file (line ${edit.line + 1}); \`${command}\` ${where}`, 15000);
  }

  /**
   * The contact sheet: the nine variations from the seed shown (seed, seed+1, …),
   * evaluated one after the other by the server and posted together. An edit or a
   * newer preview while it runs stops it (the server answers `cancelled`).
   */
  private async sheet(): Promise<void> {
    const client = this.client();
    const base = this.shownSeed;
    if (!client?.isRunning() || base === undefined) {
      void this.panel.webview.postMessage({ type: 'error', message: 'the contact sheet needs the language server to evaluate the grammar' });
      return;
    }
    const generation = ++this.generation;
    void this.panel.webview.postMessage({ type: 'busy', what: 'evaluating 9 variations…' });
    const settings = vscode.workspace.getConfiguration('mdg.preview');
    const timeBudget = settings.get<number>('timeBudget', 1);
    const maxVertices = settings.get<number>('maxVertices', 1000000);
    const items = [];
    for (let i = 0; i < 9; i++) {
      const seed = stepSeed(base, i) ?? base;
      let r: PreviewAnswer;
      try {
        r = await client.sendRequest<PreviewAnswer>('mdg/preview', {
          uri: this.doc.uri.toString(),
          seed,
          params: this.values,
          timeBudgetMs: Number.isFinite(timeBudget) && timeBudget > 0 ? Math.round(timeBudget * 1000) : undefined,
          maxVertices: Number.isFinite(maxVertices) && maxVertices > 0 ? Math.round(maxVertices) : undefined,
        });
      } catch (e) {
        if (generation === this.generation) void this.panel.webview.postMessage({ type: 'error', message: `the contact sheet failed: ${e}` });
        return;
      }
      if (generation !== this.generation || r.status === 'cancelled') return;
      if (r.status !== 'model') {
        void this.panel.webview.postMessage({ type: 'error', message: r.status === 'mode' ? `the contact sheet is for plain grammars (this one has a ${r.message} section)` : r.message });
        return;
      }
      const bytes = Buffer.from(r.glb, 'base64');
      items.push({ seed: r.seed, glb: new Uint8Array(bytes.buffer, bytes.byteOffset, bytes.byteLength), warnings: r.warnings.length });
    }
    void this.panel.webview.postMessage({ type: 'sheet', items, name: path.basename(this.doc.uri.fsPath) });
  }

  /** `mdg/preview`: the server evaluates the text it holds; the newest request wins
   * (the server stops an older run, and an older answer is dropped here). */
  private async evaluateInServer(client: LanguageClient): Promise<void> {
    const generation = ++this.generation;
    const started = Date.now();
    const editAt = this.editAt;
    void this.panel.webview.postMessage({ type: 'busy' });
    this.values = keptValues(this.values, this.declared);
    const settings = vscode.workspace.getConfiguration('mdg.preview');
    const timeBudget = settings.get<number>('timeBudget', 1);
    const maxVertices = settings.get<number>('maxVertices', 1000000);
    let r: PreviewAnswer;
    try {
      r = await client.sendRequest<PreviewAnswer>('mdg/preview', {
        uri: this.doc.uri.toString(),
        seed: this.seed,
        params: this.values,
        timeBudgetMs: Number.isFinite(timeBudget) && timeBudget > 0 ? Math.round(timeBudget * 1000) : undefined,
        maxVertices: Number.isFinite(maxVertices) && maxVertices > 0 ? Math.round(maxVertices) : undefined,
      });
    } catch (e) {
      if (generation === this.generation) {
        void this.panel.webview.postMessage({ type: 'error', message: `the language server could not evaluate the grammar: ${e}` });
      }
      return;
    }
    if (generation !== this.generation || r.status === 'cancelled') return;
    const total = Date.now() - started;
    // The debounce follows the server's work (compile, evaluation, export), not the
    // transfer: a newer edit cancels the work, while a transfer under way is wasted
    // however long the wait was.
    this.lastMs = (r.stats?.compileMs ?? 0) + (r.stats?.evalMs ?? 0) + (r.stats?.exportMs ?? 0);
    if (r.params) {
      this.declared = r.params;
      const params = this.declared.map((d) => ({ ...d, range: sliderRange(d) }));
      void this.panel.webview.postMessage({ type: 'params', params });
    }
    if (r.status === 'mode') {
      // A search, creature or grid grammar: mdg-run's own mode.
      return this.evaluateWithRun();
    }
    if (r.status === 'error') {
      void this.panel.webview.postMessage({ type: 'error', message: r.message });
      return;
    }
    this.editAt = undefined;
    this.shownSeed = r.seed;
    const bytes = Buffer.from(r.glb, 'base64');
    void this.panel.webview.postMessage({
      type: 'model',
      glb: new Uint8Array(bytes.buffer, bytes.byteOffset, bytes.byteLength),
      name: path.basename(this.doc.uri.fsPath),
      warnings: r.warnings,
      seed: r.seed,
      custom: this.seed !== undefined,
      tree: r.tree,
      editAt,
      ms: { total, compile: r.stats.compileMs, eval: r.stats.evalMs, export: r.stats.exportMs, bytes: r.stats.bytes },
    });
  }

  /** Evaluates the current text with `mdg-run`; these never overlap (one more runs after). */
  private async evaluateWithRun(): Promise<void> {
    if (this.running) {
      this.again = true;
      return;
    }
    this.running = true;
    try {
      do {
        this.again = false;
        await this.evaluateOnce();
      } while (this.again);
    } finally {
      this.running = false;
    }
  }

  private async evaluateOnce(): Promise<void> {
    const file = this.doc.uri.fsPath;
    const id = crypto.createHash('sha1').update(file).digest('hex').slice(0, 12);
    const glb = previewGlb(file, id);
    fs.mkdirSync(path.dirname(glb), { recursive: true });
    const cwd = vscode.workspace.getWorkspaceFolder(this.doc.uri)?.uri.fsPath;
    const runner = this.runPath();
    void this.panel.webview.postMessage({ type: 'busy' });
    const paramsFile = glb.replace(/\.glb$/, '.params.json');
    fs.rmSync(paramsFile, { force: true });
    this.values = keptValues(this.values, this.declared);
    const args = previewArgs(file, glb, paramsFile, this.values);
    if (this.seed !== undefined) args.push('--seed', this.seed);
    const result = await runWithInput(runner, args, cwd, this.doc.getText());
    // The declarations are written once the grammar compiles (before evaluating);
    // after a compile error the sliders of the last good text stay.
    try {
      this.declared = JSON.parse(fs.readFileSync(paramsFile, 'utf8')) as ParamDecl[];
      const params = this.declared.map((d) => ({ ...d, range: sliderRange(d) }));
      void this.panel.webview.postMessage({ type: 'params', params });
    } catch {
      // not compiled: keep the sliders
    }
    if (result.missing) {
      void this.panel.webview.postMessage({
        type: 'error',
        message: `mdg-run was not found (\`${runner}\`). Install it or set "mdg.runPath".`,
      });
      return;
    }
    if (result.code !== 0) {
      const message = result.stderr.trim() || `mdg-run exited with ${result.code}`;
      void this.panel.webview.postMessage({ type: 'error', message });
      return;
    }
    let bytes: Buffer;
    try {
      bytes = fs.readFileSync(glb);
    } catch (e) {
      void this.panel.webview.postMessage({ type: 'error', message: `cannot read ${glb}: ${e}` });
      return;
    }
    const name = path.basename(file);
    this.editAt = undefined;
    this.shownSeed = undefined;
    void this.panel.webview.postMessage({ type: 'model', glb: new Uint8Array(bytes.buffer, bytes.byteOffset, bytes.byteLength), name, warnings: [] });
  }

  private html(script: vscode.Uri): string {
    const nonce = crypto.randomBytes(16).toString('base64');
    const csp = [
      "default-src 'none'",
      `img-src ${this.panel.webview.cspSource} data: blob:`,
      `style-src 'nonce-${nonce}'`,
      `script-src 'nonce-${nonce}'`,
      `connect-src ${this.panel.webview.cspSource} data: blob:`,
    ].join('; ');
    return `<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="UTF-8">
<meta http-equiv="Content-Security-Policy" content="${csp}">
<meta name="viewport" content="width=device-width, initial-scale=1.0">
<style nonce="${nonce}">
  html, body { margin: 0; padding: 0; height: 100%; overflow: hidden; background: #1e2228; color: #ccc; font: 12px var(--vscode-font-family, sans-serif); }
  #view { width: 100%; height: 100%; display: block; }
  #bar { position: absolute; left: 0; right: 0; bottom: 0; padding: 4px 8px; background: rgba(0,0,0,0.45); display: flex; gap: 8px; align-items: center; }
  #status { flex: 1; }
  #hl { color: #ffa020; }
  #site { color: #ffd27a; font: 12px var(--vscode-editor-font-family, monospace); }
  #params { position: absolute; right: 8px; top: 8px; padding: 6px 8px; background: rgba(0,0,0,0.45); display: grid; grid-template-columns: auto 10em 3.5em; gap: 2px 6px; align-items: center; }
  #params output { text-align: right; font-variant-numeric: tabular-nums; }
  #error { position: absolute; left: 8px; right: 8px; top: 8px; margin: 0; padding: 8px; max-height: 60%; overflow: auto; white-space: pre-wrap;
           background: rgba(90,20,20,0.92); color: #fdd; border: 1px solid #c55; font: 12px var(--vscode-editor-font-family, monospace); }
  #warn { position: absolute; left: 8px; right: 8px; bottom: 34px; margin: 0; padding: 6px 8px; max-height: 30%; overflow: auto; white-space: pre-wrap;
          background: rgba(90,70,10,0.92); color: #fec; border: 1px solid #c92; font: 12px var(--vscode-editor-font-family, monospace); }
  #sheet { position: absolute; left: 0; top: 0; right: 0; bottom: 30px; display: grid; grid-template-columns: repeat(3, 1fr); grid-template-rows: repeat(3, 1fr); }
  #sheet div { border: 1px solid rgba(255,255,255,0.15); cursor: pointer; display: flex; align-items: flex-end; justify-content: center; }
  #sheet div:hover { border-color: #ffa020; }
  #sheet span { background: rgba(0,0,0,0.5); padding: 1px 6px; margin-bottom: 4px; font-variant-numeric: tabular-nums; }
  #seedbox { display: flex; gap: 2px; align-items: center; }
  #seed { width: 8em; font: inherit; }
  #tree { position: absolute; left: 8px; top: 8px; bottom: 40px; width: 24em; max-width: 48%; display: flex; flex-direction: column; background: rgba(0,0,0,0.6); border: 1px solid rgba(255,255,255,0.15); }
  #treehead { display: flex; gap: 6px; align-items: center; padding: 4px 6px; border-bottom: 1px solid rgba(255,255,255,0.15); }
  #treehead b { flex: 1; }
  #depth { width: 7em; }
  #depthlabel { font-variant-numeric: tabular-nums; white-space: nowrap; }
  #treenote { margin: 0; padding: 2px 6px; color: #fec; }
  #treelist { flex: 1; overflow: auto; padding: 2px 0; font: 12px var(--vscode-editor-font-family, monospace); }
  #treelist .row { white-space: nowrap; cursor: pointer; padding-right: 6px; }
  #treelist .row:hover { background: rgba(255,255,255,0.08); }
  #treelist .row.lit { background: rgba(255,160,32,0.35); }
  #treelist .caret { display: inline-block; width: 1em; color: #999; }
  #treelist .rule { color: #9cdcfe; }
  #treelist .info { color: #bbb; }
  #treelist .place { color: #ffd27a; margin-left: 6px; text-decoration: underline; }
  button { font: inherit; }
  [hidden] { display: none !important; }
</style>
</head>
<body>
<canvas id="view"></canvas>
<div id="params" hidden></div>
<pre id="error" hidden></pre>
<pre id="warn" hidden></pre>
<div id="sheet" hidden></div>
<div id="tree" hidden><div id="treehead"><b>Derivation</b><span id="depthbox" hidden title="Show what derivation depths up to N made (the start shape's body is depth 0)"><input id="depth" type="range" min="0" max="0" step="1" aria-label="depth"> <span id="depthlabel"></span></span></div><p id="treenote" hidden></p><div id="treelist"></div></div>
<div id="bar"><span id="status">evaluating…</span><span id="seedbox" hidden title="The seed of this variation: type one, or [ and ] (or P and N) for the previous and next"><button id="prev" title="Previous variation ([ or P)">◀</button><label for="seed">seed</label><input id="seed" inputmode="numeric" spellcheck="false"><button id="next" title="Next variation (] or N)">▶</button><button id="keep" title="Keep this variation: write randseed into the file (K)">Keep</button><button id="sheetbutton" title="A contact sheet of 9 variations from this seed (S); click one to choose it">3×3</button></span><button id="treebutton" aria-pressed="false" title="The derivation inspector: the tree of rule calls, and a depth slider (T)">Tree</button><span id="site" hidden></span><span id="hl" hidden></span><button id="guides" hidden aria-pressed="true" title="Show or hide the guides and bones (G)">Hide guides</button><button id="play" hidden>Pause</button><span id="time" hidden></span></div>
<script nonce="${nonce}" src="${script}"></script>
</body>
</html>`;
  }
}
