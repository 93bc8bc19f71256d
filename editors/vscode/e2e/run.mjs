// The MDG extension in a real VS Code: code-server 4.100.3 (VS Code 1.100.3)
// driven by headless Debian Chromium through playwright-core (no browser download).
// Started by lsp/tests/vscode.rs, which prepares the workspace and packages the
// .vsix; every check below is an assertion on what VS Code shows or writes.
//
// Environment:
//   MDG_E2E_DIR    where install.sh put code-server and playwright-core
//   MDG_VSIX       the freshly packaged extension
//   MDG_LSP        the mdg-lsp binary; MDG_STD the std directory; MDG_RUN mdg-run
//   MDG_WORKSPACE  the folder to open (std examples, a library and its importers)
//   MDG_SHOTS      the folder screenshots are written to (one per check)
//   MDG_RESULTS    the JSON file the check results are written to
//   MDG_CHROMIUM   the Chromium binary (default /usr/lib/chromium/chromium)

import { createRequire } from 'node:module';
import { spawn, execFileSync } from 'node:child_process';
import * as fs from 'node:fs';
import * as path from 'node:path';
import * as net from 'node:net';

const env = (k, d) => {
  const v = process.env[k] ?? d;
  if (v === undefined) throw new Error(`${k} is not set`);
  return v;
};
const e2eDir = env('MDG_E2E_DIR');
const vsix = env('MDG_VSIX');
const lsp = env('MDG_LSP');
const std = env('MDG_STD');
const mdgRun = env('MDG_RUN');
const ws = env('MDG_WORKSPACE');
const shots = env('MDG_SHOTS');
const resultsFile = env('MDG_RESULTS');
const chromiumPath = env('MDG_CHROMIUM', '/usr/lib/chromium/chromium');
const require = createRequire(path.join(e2eDir, 'package.json'));
const { chromium } = require('playwright-core');
const entry = path.join(e2eDir, 'node_modules/code-server/out/node/entry.js');

const results = [];
let shotNo = 0;
const t0 = Date.now();
const log = (m) => console.log(`[${((Date.now() - t0) / 1000).toFixed(1)} s] ${m}`);

function freePort() {
  return new Promise((resolve, reject) => {
    const s = net.createServer();
    s.listen(0, '127.0.0.1', () => {
      const { port } = s.address();
      s.close(() => resolve(port));
    });
    s.on('error', reject);
  });
}

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

async function until(what, fn, timeout = 30000) {
  const end = Date.now() + timeout;
  let last;
  while (Date.now() < end) {
    try {
      const v = await fn();
      if (v) return v;
    } catch (e) {
      last = e;
    }
    await sleep(200);
  }
  throw new Error(`timed out waiting for ${what}${last ? `: ${last.message}` : ''}`);
}

// --- code-server: fresh profile, the extension installed, then served. ---
const home = fs.mkdtempSync(path.join(path.dirname(resultsFile), 'code-server-'));
const userData = path.join(home, 'user-data');
const extDir = path.join(home, 'extensions');
fs.mkdirSync(path.join(userData, 'User'), { recursive: true });
fs.writeFileSync(
  path.join(userData, 'User', 'settings.json'),
  JSON.stringify(
    {
      'mdg.serverPath': lsp,
      'mdg.stdPath': std,
      'mdg.runPath': mdgRun,
      'security.workspace.trust.enabled': false,
      'workbench.startupEditor': 'none',
      'workbench.tips.enabled': false,
      'workbench.enableExperiments': false,
      'workbench.secondarySideBar.defaultVisibility': 'hidden',
      'chat.commandCenter.enabled': false,
      'telemetry.telemetryLevel': 'off',
      'update.mode': 'none',
      'extensions.autoCheckUpdates': false,
      'extensions.ignoreRecommendations': true,
      'editor.minimap.enabled': false,
      'editor.hover.delay': 150,
      'editor.quickSuggestions': { other: false, comments: false, strings: false },
      'files.autoSave': 'off',
      'window.restoreWindows': 'none',
      'workbench.colorTheme': 'Default Dark Modern',
    },
    null,
    2,
  ),
);
const port = await freePort();
const config = path.join(home, 'config.yaml');
fs.writeFileSync(config, `bind-addr: 127.0.0.1:${port}\nauth: none\ncert: false\n`);
const csArgs = ['--config', config, '--user-data-dir', userData, '--extensions-dir', extDir];
log('installing the extension');
execFileSync('node', [entry, ...csArgs, '--install-extension', vsix], { stdio: 'inherit' });
const installed = fs.readdirSync(extDir).filter((d) => d.startsWith('mdg.mdg-'));
if (installed.length !== 1) throw new Error(`the extension is not installed: ${fs.readdirSync(extDir)}`);
const server = spawn('node', [entry, ...csArgs, '--disable-workspace-trust', ws], {
  stdio: ['ignore', 'pipe', 'pipe'],
  env: { ...process.env, HOME: home },
});
let serverLog = '';
server.stdout.on('data', (d) => (serverLog += d));
server.stderr.on('data', (d) => (serverLog += d));
const base = `http://127.0.0.1:${port}`;
await until('code-server /healthz', async () => (await fetch(`${base}/healthz`)).ok, 60000);
log(`code-server on ${base}`);

const browser = await chromium.launch({
  executablePath: chromiumPath,
  headless: true,
  // WebGL for the preview panel, on the CPU.
  args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist'],
});
const page = await browser.newPage({ viewport: { width: 1400, height: 900 } });
const mod = 'Control';

async function shot(name) {
  shotNo += 1;
  const file = path.join(shots, `${String(shotNo).padStart(2, '0')}-${name}.png`);
  await page.screenshot({ path: file });
  return file;
}

async function check(name, fn) {
  const start = Date.now();
  try {
    const detail = await fn();
    const file = await shot(name);
    results.push({ name, ok: true, ms: Date.now() - start, detail: detail ?? '', screenshot: file });
    log(`ok   ${name} ${detail ?? ''}`);
  } catch (e) {
    let file = '';
    try {
      file = await shot(`${name}-FAILED`);
    } catch {}
    results.push({ name, ok: false, ms: Date.now() - start, detail: String(e?.stack ?? e), screenshot: file });
    log(`FAIL ${name}: ${e?.message ?? e}`);
  }
}

/** The visible text of the active editor (Monaco renders spaces as U+00A0). */
async function editorText() {
  return (await page.locator('.editor-instance .monaco-editor .view-lines:visible').first().innerText()).replace(/\u00a0/g, ' ');
}

/**
 * Opens a quick input with `key` and types `text` into it. The widget can close again at
 * once when a webview (the preview) held the focus as the key went down; under load that
 * happened in CI. Then it tries again from the workbench.
 */
async function quickInput(key, text) {
  const input = page.locator('.quick-input-widget input');
  for (let attempt = 1; ; attempt++) {
    try {
      await page.keyboard.press(key);
      await input.waitFor({ state: 'visible', timeout: 10000 });
      await input.fill(text, { timeout: 5000 });
      return input;
    } catch (e) {
      if (attempt === 3) throw e;
      log(`quick input for ${text} closed before typing (attempt ${attempt}); retrying`);
      await page.keyboard.press('Escape');
      await page.locator('.part.sidebar').first().click({ position: { x: 5, y: 5 } }).catch(() => {});
      await sleep(500);
    }
  }
}

/** Runs a command from the command palette by its title. */
async function palette(title) {
  const input = await quickInput('F1', `>${title}`);
  await page.locator('.quick-input-list .monaco-list-row', { hasText: title }).first().waitFor({ state: 'visible' });
  await sleep(200);
  await page.keyboard.press('Enter');
  await input.waitFor({ state: 'hidden' });
}

/** Opens a workspace file with Quick Open and waits for its editor. */
async function openFile(rel) {
  const input = await quickInput(`${mod}+KeyP`, rel);
  const name = path.basename(rel);
  await page.locator('.quick-input-list .monaco-list-row', { hasText: name }).first().waitFor({ state: 'visible' });
  await sleep(300);
  await page.keyboard.press('Enter');
  await page.locator(`.tab.active[aria-label^="${name}"]`).waitFor({ state: 'visible', timeout: 20000 });
  await page.locator('.editor-instance .monaco-editor .view-lines:visible').first().waitFor({ state: 'visible' });
  await sleep(300);
}

/** Puts the cursor on the first visible occurrence of a word (by clicking it). */
async function clickWord(word, nth = 0) {
  const span = page.locator('.editor-instance .view-lines:visible span span', { hasText: new RegExp(`^${word}$`) }).nth(nth);
  await span.waitFor({ state: 'visible' });
  const box = await span.boundingBox();
  await page.mouse.click(box.x + Math.min(box.width / 2, 6), box.y + box.height / 2);
  return span;
}

const readWs = (rel) => fs.readFileSync(path.join(ws, rel), 'utf8');

try {
  await page.goto(`${base}/?folder=${encodeURIComponent(ws)}`);
  await page.locator('.monaco-workbench').waitFor({ state: 'visible', timeout: 60000 });
  await until('the explorer', () => page.locator('.explorer-folders-view').isVisible(), 60000);
  log('workbench loaded');

  await check('highlighting', async () => {
    await openFile('examples/tree.mdg');
    // TextMate and semantic tokens give the keyword, the rule names and the
    // numbers their own colours.
    // A line re-rendered (semantic tokens arriving) detaches the span read a moment
    // before, whose style is then empty: read again until there is a colour.
    const colour = (word) =>
      until(`the colour of ${word}`, async () => {
        const s = page.locator('.editor-instance .view-lines:visible span span', { hasText: new RegExp(`^${word}$`) }).first();
        await s.waitFor({ state: 'visible' });
        return (await s.evaluate((el) => getComputedStyle(el).color)) || undefined;
      });
    const keyword = await colour('startshape');
    const rule = await until('semantic colouring of a rule call', async () => {
      const c = await colour('tree');
      return c !== (await colour('randseed')) ? c : undefined;
    });
    const number = await colour('7');
    const comment = await page
      .locator('.editor-instance .view-lines:visible span span', { hasText: /^\/\/.A.random.tree/ })
      .first()
      .evaluate((el) => getComputedStyle(el).color);
    const distinct = new Set([keyword, rule, number, comment]);
    if (distinct.size < 4 || ![...distinct].every((c) => c.startsWith('rgb'))) throw new Error(`keyword ${keyword}, rule ${rule}, number ${number}, comment ${comment}: not 4 colours`);
    return `keyword ${keyword}, rule call ${rule}, number ${number}, comment ${comment}`;
  });

  await check('hover', async () => {
    const span = await clickWord('disc');
    await span.hover();
    const hover = page.locator('.monaco-hover:not(.hidden)').filter({ hasText: 'disc' }).first();
    await hover.waitFor({ state: 'visible', timeout: 15000 });
    const text = await hover.innerText();
    if (!/rule/.test(text)) throw new Error(`hover text: ${text}`);
    return JSON.stringify(text.slice(0, 80));
  });

  await check('definition into std', async () => {
    await page.mouse.move(0, 0);
    await page.keyboard.press('Escape');
    await clickWord('disc');
    await page.keyboard.press('F12');
    await page.locator('.tab.active[aria-label^="primitives.mdg"]').waitFor({ state: 'visible', timeout: 15000 });
    const text = await editorText();
    if (!text.includes('rule disc')) throw new Error('the definition is not shown');
    return 'primitives.mdg: rule disc';
  });

  await check('diagnostic after typing', async () => {
    await openFile('scratch.mdg');
    await page.keyboard.press(`${mod}+End`);
    // A second definition of the start rule, calling a rule that does not exist.
    await page.keyboard.type('\nrule S { nope {} }\n');
    await page.locator('.editor-instance .squiggly-error').first().waitFor({ state: 'visible', timeout: 15000 });
    // Typed a key at a time, earlier versions had other errors: wait for the last.
    let text = '';
    await until('the E0301 problem', async () => {
      await page.keyboard.press('Escape');
      await page.keyboard.press('F8');
      const widget = page.locator('.zone-widget').first();
      await widget.waitFor({ state: 'visible', timeout: 5000 });
      text = await widget.innerText();
      return text.includes('E0301') && text.includes('nope');
    }, 20000);
    await page.keyboard.press('Escape');
    await sleep(300);
    return JSON.stringify(text.split('\n').find((l) => l.includes('nope')));
  });

  await check('quick fix', async () => {
    await clickWord('nope');
    await page.keyboard.press(`${mod}+Period`);
    const item = page.locator('.action-widget .monaco-list-row', { hasText: 'Create rule `nope`' }).first();
    await item.waitFor({ state: 'visible', timeout: 10000 });
    // The menu takes the keyboard: walk to the fix, then accept it.
    const focused = page.locator('.action-widget .monaco-list-row.focused');
    for (let i = 0; i < 10 && !((await focused.innerText().catch(() => '')).includes('Create rule `nope`')); i++) {
      await page.keyboard.press('ArrowDown');
      await sleep(100);
    }
    await page.keyboard.press('Enter');
    await until('the created rule', async () => (await editorText()).includes('rule nope'), 10000);
    await until('the error to go', async () => (await page.locator('.editor-instance .squiggly-error').count()) === 0, 15000);
    return 'rule nope created, no error left';
  });

  await check('completion', async () => {
    await page.keyboard.press(`${mod}+End`);
    await page.keyboard.type('rule more {\n');
    await page.keyboard.type('pet');
    await page.keyboard.press(`${mod}+Space`);
    const row = page.locator('.suggest-widget .monaco-list-row', { hasText: 'petal' }).first();
    await row.waitFor({ state: 'visible', timeout: 15000 });
    const labels = await page.locator('.suggest-widget .monaco-list-row .label-name').allInnerTexts();
    await page.keyboard.press('Enter');
    await until('the accepted completion', async () => /petal/.test((await editorText()).split('rule more')[1] ?? ''), 5000);
    return `offered ${labels.slice(0, 5).join(', ')}`;
  });

  await check('format', async () => {
    await openFile('messy.mdg');
    await palette('Format Document');
    await until('the formatted text', async () => (await editorText()).includes('  VERTEX {y 1}\n'), 10000);
    await page.keyboard.press(`${mod}+KeyS`);
    const want = 'startshape A\nrule A {\n  VERTEX {x 1}\n  VERTEX {y 1}\n  VERTEX {}\n}\n';
    await until('the formatted file on disk', async () => readWs('messy.mdg') === want, 10000);
    return 'messy.mdg formatted and saved';
  });

  await check('rename across two importers', async () => {
    await openFile('lib/parts.mdg');
    await clickWord('petal');
    // Away from the word, so no hover is left over it; retry F2 if the box never
    // takes the keyboard (seen under heavy load).
    await page.mouse.move(5, 5);
    const box = page.locator('.rename-box').first();
    const focused = () =>
      box.evaluate((el) => {
        const a = document.activeElement;
        return !!a && el.contains(a) && ((a.value ?? a.textContent) || '').includes('petal');
      });
    let ready = false;
    for (let attempt = 0; attempt < 3 && !ready; attempt++) {
      await page.keyboard.press('F2');
      ready = await until('the rename box to take the keyboard', focused, 8000).catch(async (e) => {
        const where = await box
          .evaluate((el) => `active: ${document.activeElement?.outerHTML.slice(0, 300)}; box: ${el.innerHTML.slice(0, 300)}`)
          .catch(() => 'no rename box');
        log(`rename attempt ${attempt + 1}: ${e.message}; ${where}`);
        await page.keyboard.press('Escape');
        await clickWord('petal');
        await page.mouse.move(5, 5);
        return false;
      });
    }
    if (!ready) throw new Error('the rename box never took the keyboard');
    await page.keyboard.type('bloom');
    await page.keyboard.press('Enter');
    await until('the renamed definition', async () => (await editorText()).includes('rule bloom'), 10000);
    await palette('File: Save All');
    const files = ['garden.mdg', 'meadow.mdg', 'lib/parts.mdg'];
    await until(
      'the importers renamed on disk',
      async () => files.every((f) => readWs(f).includes('bloom') && !readWs(f).includes('petal')),
      15000,
    );
    return files.map((f) => `${f}: ${readWs(f).split('bloom').length - 1}×bloom`).join(', ');
  });

  await check('code lenses', async () => {
    // lib/parts.mdg is open after the rename: its rule's count covers the importers
    // (garden once, meadow twice, and the scratch file), open or not.
    const lenses = () => page.locator('.editor-instance .codelens-decoration:visible a');
    const refs = lenses().filter({ hasText: /^\d+ references?$/ }).first();
    await refs.waitFor({ state: 'visible', timeout: 30000 });
    const count = await refs.innerText();
    if (Number(count.split(' ')[0]) < 3) throw new Error(`lens: ${count}`);
    await refs.click();
    const peek = page.locator('.peekview-widget').first();
    await peek.waitFor({ state: 'visible', timeout: 15000 });
    const files = await until('the peeked references', async () => {
      const t = (await peek.innerText().catch(() => '')).replace(/\s+/g, ' ');
      return t.includes('garden.mdg') && t.includes('meadow.mdg') ? t : undefined;
    }, 15000);
    await shot('code-lens-references');
    await page.keyboard.press('Escape');
    await openFile('garden.mdg');
    const all = await until('the run lenses over startshape', async () => {
      const texts = await lenses().allInnerTexts();
      return ['Preview', 'Render .glb', 'Stats'].every((w) => texts.some((t) => t.includes(w))) ? texts : undefined;
    }, 30000);
    return `${count} (peek: ${files.slice(0, 60)}…); garden.mdg: ${all.join(' | ')}`;
  });

  // The live preview: the model, then the changed model after an edit (not
  // saved: the editor's text is evaluated), then an error shown in the panel.
  const preview = () => page.frameLocator('iframe.webview').frameLocator('iframe#active-frame');
  // The preview frame of a file, among every webview's frames.
  const previewOf = (name) =>
    until(`the preview of ${name}`, async () => {
      for (const f of page.frames()) {
        const t = await f.locator('#status').innerText({ timeout: 200 }).catch(() => '');
        if (t.startsWith(`${name}:`)) return f;
      }
      return undefined;
    }, 30000);
  const triangles = async () => Number((await preview().locator('#status').getAttribute('data-triangles', { timeout: 1000 })) ?? -1);
  await check('preview panel', async () => {
    await openFile('garden.mdg');
    await palette('MDG: Preview');
    await preview().locator('#status[data-triangles]').waitFor({ state: 'attached', timeout: 30000 });
    const status = await preview().locator('#status').innerText();
    if (!/garden\.mdg: \d+ triangles/.test(status)) throw new Error(`status: ${status}`);
    const n = await triangles();
    if (n <= 0) throw new Error(`no triangles: ${status}`);
    await sleep(500);
    return status;
  });

  await check('preview after an edit', async () => {
    const before = await triangles();
    await page.locator('.editor-instance .monaco-editor .view-lines:visible').first().click();
    await page.keyboard.press(`${mod}+KeyG`);
    await page.keyboard.type('4');
    await page.keyboard.press('Enter');
    await page.keyboard.press('End');
    await page.keyboard.type(' bloom {x 2}');
    const after = await until('the re-evaluated model', async () => {
      const n = await triangles();
      return n !== before ? n : undefined;
    }, 20000);
    if (after !== before + 1) throw new Error(`triangles ${before} → ${after}, expected one more`);
    await sleep(500);
    return `${before} → ${after} triangles without saving`;
  });

  await check('preview shows errors', async () => {
    await page.keyboard.type(' nope {}');
    const box = preview().locator('#error');
    await box.waitFor({ state: 'visible', timeout: 20000 });
    // The preview follows the typing: the text in between (` nope` before its
    // braces) may show its own error first.
    let text = '';
    try {
      text = await until('the unknown rule error', async () => {
        const t = await box.innerText();
        return t.includes('E0301') && t.includes('nope') ? t : undefined;
      }, 20000);
    } catch {
      throw new Error(`error box: ${await box.innerText()}`);
    }
    return JSON.stringify(text.split('\n')[0]);
  });

  await check('preview animation', async () => {
    await openFile('examples/solar_system.mdg');
    await palette('MDG: Preview');
    const frame = await previewOf('solar_system.mdg');
    const text = await frame.locator('#status').innerText();
    if (!/animation/.test(text)) throw new Error(`no animation: ${text}`);
    const time = frame.locator('#time');
    await time.waitFor({ state: 'visible' });
    const t1 = await time.innerText();
    const t2 = await until('the animation to play', async () => {
      const t = await time.innerText();
      return t !== t1 ? t : undefined;
    }, 5000);
    await frame.locator('#play').click();
    const t3 = await time.innerText();
    await sleep(500);
    if ((await time.innerText()) !== t3) throw new Error('Pause does not stop the animation');
    return `${text}; playing ${t1} → ${t2}, paused at ${t3}`;
  });
  await check('preview of a std example', async () => {
    await palette('View: Single Column Editor Layout');
    await openFile('examples/tree.mdg');
    await palette('MDG: Preview');
    const frame = await previewOf('tree.mdg');
    const text = await frame.locator('#status').innerText();
    if (!/tree\.mdg: \d{4,} triangles/.test(text)) throw new Error(`status: ${text}`);
    await sleep(1000);
    return text;
  });

  // Keystroke → new frame drawn, in the previews of two std examples: each key in a
  // comment at the end of the file is a new text, so a new model (evaluated by the
  // language server) and a new frame; the webview stamps the frame (data-drawn-at,
  // Date.now() in the same browser as the key). The next key waits for the frame.
  // (Light examples: the panel draws with SwiftShader, on the CPU.)
  const attr = async (frame, name) => frame.locator('#status').getAttribute(name, { timeout: 5000 });
  // The editor of `name` (the group whose active tab it is: the panel beside it may have the focus).
  const editorOf = (name) =>
    page.locator('.editor-group-container', { has: page.locator(`.tab.active[aria-label^="${name}"]`) }).locator('.monaco-editor .view-lines').first();
  await check('preview keystroke to frame', async () => {
    const all = [];
    const each = [];
    for (const file of ['examples/cube_spiral.mdg', 'examples/koch_snowflake.mdg']) {
      await openFile(file);
      await palette('MDG: Preview');
      const frame = await previewOf(path.basename(file));
      await editorOf(path.basename(file)).click();
      await page.keyboard.press(`${mod}+End`);
      await page.keyboard.press('Enter');
      await page.keyboard.type('// ');
      await sleep(1500);
      const times = [];
      for (const ch of 'variation!') {
        const drawn = Number((await attr(frame, 'data-drawn')) ?? 0);
        const at0 = await page.evaluate(() => Date.now());
        await page.keyboard.type(ch);
        const end = Date.now() + 20000;
        while (Number((await attr(frame, 'data-drawn')) ?? 0) <= drawn) {
          if (Date.now() > end) throw new Error(`no new frame after typing ${JSON.stringify(ch)} in ${file}`);
          await sleep(10);
        }
        times.push(Number(await attr(frame, 'data-drawn-at')) - at0);
        await sleep(150);
      }
      all.push(...times);
      each.push(`${path.basename(file)}: ${times.join(', ')} ms`);
    }
    const sorted = [...all].sort((a, b) => a - b);
    const pick = (q) => sorted[Math.min(sorted.length - 1, Math.ceil(q * sorted.length) - 1)];
    return `keystroke → frame over ${all.length} keys: median ${pick(0.5)} ms, p95 ${pick(0.95)} ms (${each.join('; ')})`;
  });

  // Variations (pebbles.mdg, random): the next seed (the ▶ button), the previous
  // (the P key in the panel), then Keep writes `randseed N` into the file.
  await check('preview variations', async () => {
    await openFile('examples/pebbles.mdg');
    await palette('MDG: Preview');
    const frame = await previewOf('pebbles.mdg');
    const seed0 = await attr(frame, 'data-seed');
    if (seed0 === null) throw new Error('no seed shown');
    const next = String(BigInt(seed0) + 1n);
    await frame.locator('#next').click();
    await until(`seed ${next}`, async () => (await attr(frame, 'data-seed')) === next, 20000);
    const t1 = await attr(frame, 'data-triangles');
    await frame.locator('#status').click();
    await page.keyboard.press('KeyP');
    await until(`seed ${seed0} again`, async () => (await attr(frame, 'data-seed')) === seed0, 20000);
    await frame.locator('#next').click();
    await until(`seed ${next} again`, async () => (await attr(frame, 'data-seed')) === next, 20000);
    await sleep(500);
    await shot('preview-variation');
    const drawnBeforeKeep = Number((await attr(frame, 'data-drawn')) ?? 0);
    await frame.locator('#keep').click();
    await until(`randseed ${next} in the file`, async () => (await editorOf('pebbles.mdg').innerText()).replace(/\u00a0/g, ' ').includes(`randseed ${next}`), 10000);
    // The contact sheet: nine variations from the seed shown; a click chooses one.
    // (After the model of the edited file: its evaluation would stop the sheet's.)
    await until('the model after Keep', async () => Number((await attr(frame, 'data-drawn')) ?? 0) > drawnBeforeKeep, 20000);
    await frame.locator('#sheetbutton').click();
    await until('the contact sheet', async () => (await attr(frame, 'data-sheet')) === '9', 60000);
    await sleep(1000);
    await shot('preview-contact-sheet');
    const cells = await frame.locator('#sheet div').evaluateAll((l) => l.map((e) => e.dataset.seed));
    if (cells.length !== 9 || cells[0] !== next || cells[8] !== String(BigInt(next) + 8n)) throw new Error(`sheet seeds ${cells.join(', ')}`);
    await frame.locator('#sheet div').nth(4).click();
    await until(`seed ${cells[4]} chosen`, async () => (await attr(frame, 'data-seed')) === cells[4] && (await attr(frame, 'data-sheet')) === null, 20000);
    return `seed ${seed0} → ${next} (${t1} triangles) → ${seed0} → ${next}, kept: randseed ${next} in pebbles.mdg; contact sheet of seeds ${cells[0]}…${cells[8]}, the middle one chosen (${cells[4]})`;
  });

  // A runaway grammar (a recursion that never ends, drawing nothing after its
  // first triangle) is cut by the preview's time budget with a warning naming the
  // setting, and the next edit previews again.
  await check('preview runaway grammar', async () => {
    const frame = await previewOf('pebbles.mdg');
    await editorOf('pebbles.mdg').click();
    await page.keyboard.press(`${mod}+KeyA`);
    await page.keyboard.press('Delete');
    // Inserted at once (typed, the editor would close the braces by itself).
    const typed = Date.now();
    await page.keyboard.insertText('startshape s\nrule tri { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\nrule s { tri {} a {} }\nrule a { a {x 1} a {y 1} }');
    const warn = frame.locator('#warn');
    await warn.waitFor({ state: 'visible', timeout: 20000 });
    const shownAfter = Date.now() - typed;
    const text = await warn.innerText();
    // Which limit comes first depends on the machine's speed: the time budget, or
    // `maxiter`'s 10,000,000 calls; each warning says how to raise it.
    if (!/(time budget|maxiter \d+) reached/.test(text) || !/raise the limit with/.test(text)) throw new Error(`warning: ${text}`);
    await sleep(500);
    await shot('preview-runaway');
    // The recursion removed: one triangle, no warning.
    await editorOf('pebbles.mdg').click();
    await page.keyboard.press(`${mod}+End`);
    await page.keyboard.press('Shift+Home');
    await page.keyboard.insertText('rule a { tri {} }');
    await until('the mended model', async () => (await attr(frame, 'data-triangles')) === '2' && !(await warn.isVisible()), 20000);
    const limit = text.split('\n').find((l) => /(time budget|maxiter \d+) reached/.test(l)) ?? '';
    return `warning shown ${shownAfter} ms after the runaway text was inserted: ${JSON.stringify(limit.slice(0, 240))}; then the mended model`;
  });

  // A guided grammar: the search's guides and bones drawn over the model, toggled
  // by the button (and G); the status counts them.
  await check('preview guides and bones', async () => {
    await openFile('examples/guided_tree.mdg');
    await palette('MDG: Preview');
    const frame = await previewOf('guided_tree.mdg');
    const status = frame.locator('#status');
    const bones = Number(await status.getAttribute('data-bones'));
    const guides = Number(await status.getAttribute('data-guides'));
    if (!(bones > 10 && guides > 10)) throw new Error(`bones ${bones}, guide segments ${guides}: ${await status.innerText()}`);
    const button = frame.locator('#guides');
    await button.waitFor({ state: 'visible' });
    if ((await button.getAttribute('aria-pressed')) !== 'true') throw new Error('the overlays start hidden');
    await button.click();
    if ((await button.getAttribute('aria-pressed')) !== 'false') throw new Error('the button does not hide them');
    await button.click();
    if ((await button.getAttribute('aria-pressed')) !== 'true') throw new Error('the button does not show them again');
    await sleep(500);
    return await status.innerText();
  });

  // `@param` sliders: one per declaration, with its declared range; moving one
  // (the keyboard: Home is the minimum) re-runs mdg-run with `--param`.
  await check('preview sliders', async () => {
    await openFile('examples/parametric_tree.mdg');
    await palette('MDG: Preview');
    const frame = await previewOf('parametric_tree.mdg');
    const levels = frame.locator('input[data-name="levels"]');
    await levels.waitFor({ state: 'visible', timeout: 30000 });
    const names = await frame.locator('#params input').evaluateAll((l) => l.map((e) => `${e.dataset.name} ${e.min}..${e.max}`));
    if (names.join(', ') !== 'levels 1..7, forks 2..5, spread 5..60') throw new Error(`sliders: ${names.join(', ')}`);
    const count = async () => Number((await frame.locator('#status').getAttribute('data-triangles', { timeout: 1000 })) ?? -1);
    const before = await count();
    await levels.focus();
    await page.keyboard.press('Home');
    const after = await until('the model with levels=1', async () => {
      const n = await count();
      return n !== before ? n : undefined;
    }, 30000);
    if (!(after > 0 && after < before)) throw new Error(`triangles ${before} → ${after}, expected fewer`);
    const shown = await frame.locator('#params output').first().innerText();
    if (shown !== '1') throw new Error(`levels shows ${shown}`);
    await sleep(500);
    return `levels 5 → 1: ${before} → ${after} triangles`;
  });

  // A click on the model (no drag) names the rule and line that drew the instance
  // under the pointer (`mdg-run --sites`) and shows that line in the editor.
  await check('preview click names the rule', async () => {
    // Four petals around the origin: the middle of the view is the model.
    await openFile('pinwheel.mdg');
    await palette('MDG: Preview');
    const frame = await previewOf('pinwheel.mdg');
    const view = frame.locator('#view');
    const box = await view.boundingBox();
    const site = frame.locator('#site');
    let label = '';
    // The middle of the view may be sky between the branches: try a few points.
    for (const [fx, fy] of [[0.5, 0.5], [0.5, 0.6], [0.45, 0.55], [0.55, 0.45], [0.5, 0.4], [0.5, 0.7], [0.4, 0.5], [0.6, 0.5]]) {
      await view.click({ position: { x: box.width * fx, y: box.height * fy } });
      await sleep(300);
      if (await site.isVisible()) {
        label = await site.innerText();
        break;
      }
    }
    const m = /^(\S+) · (\S+):(\d+)$/.exec(label);
    if (!m) throw new Error(`no site named after clicking the model: ${JSON.stringify(label)}`);
    // The petal is a prototype (a rule of VERTEXes only): the preview draws the
    // four instanced, and the click named the rule of the instance it hit.
    if ((await site.getAttribute('data-instance')) !== 'true') throw new Error('the click did not hit an instance: the petals are not drawn instanced');
    const [, rule, file, line] = m;
    await page.locator(`.tab.active[aria-label^="${path.basename(file)}"]`).waitFor({ state: 'visible', timeout: 15000 });
    const cursor = await until('the cursor on the line', async () => {
      const t = await page.locator('.statusbar-item[id="status.editor.selection"]').innerText({ timeout: 1000 }).catch(() => '');
      return new RegExp(`Ln ${line},`).test(t) ? t : undefined;
    }, 10000);
    // The active group's editor (earlier checks left several side by side).
    const text = (await page.locator('.editor-group-container.active .monaco-editor .view-lines').first().innerText()).replace(/\u00a0/g, ' ');
    if (!text.includes(`rule ${rule.split('.').pop()}`)) throw new Error(`rule ${rule} not shown in ${file}`);
    return `${label}; the editor shows ${path.basename(file)} at ${cursor}`;
  });

  // Cursor → geometry: the cursor on a rule's name lights up the triangles that rule
  // drew (all four petals of the pinwheel: `bloom`, as the rename check named the
  // library's petal); on a line outside every rule, none.
  await check('preview cursor highlights the rule', async () => {
    await openFile('pinwheel.mdg');
    const frame = await previewOf('pinwheel.mdg');
    const lit = async () => Number((await frame.locator('#status').getAttribute('data-highlighted', { timeout: 1000 })) ?? -1);
    const total = Number(await frame.locator('#status').getAttribute('data-triangles'));
    // (In pinwheel's editor: earlier checks left other editors open beside it.)
    const clickHere = async (word) => {
      const span = editorOf('pinwheel.mdg').locator('span span', { hasText: new RegExp(`^${word}$`) }).first();
      await span.waitFor({ state: 'visible' });
      const box = await span.boundingBox();
      await page.mouse.click(box.x + Math.min(box.width / 2, 6), box.y + box.height / 2);
    };
    await clickHere('bloom');
    const n = await until('the petals lit', async () => ((await lit()) > 0 ? await lit() : undefined), 15000);
    if (n !== total) throw new Error(`${n} of ${total} triangles lit for rule bloom`);
    const label = await frame.locator('#hl').innerText();
    await sleep(500);
    await shot('preview-highlight');
    await clickHere('startshape');
    await until('the light off', async () => (await lit()) === 0, 15000);
    return `${label} (of ${total}); off on the startshape line`;
  });

  // Cursor → geometry on sweeps and instances: std/examples/icosahedron.mdg is
  // the regular solids of std/polyhedra, vertices as SPHERE isosurface instances
  // (drawn instanced) and edges as LINETO sweeps. The cursor on `tetrahedron`
  // lights its own ops' 4 SPHEREs; on `solids`, a rule that only calls others,
  // what its calls made: the whole model, spheres and tubes.
  const lit = async (frame) => Number((await frame.locator('#status').getAttribute('data-highlighted', { timeout: 1000 })) ?? -1);
  const litInstances = async (frame) => Number(await frame.locator('#status').getAttribute('data-highlighted-instances', { timeout: 1000 }));
  const clickIn = async (file, word, nth) => {
    const span = editorOf(file).locator('span span', { hasText: new RegExp(`^${word}$`) }).nth(nth);
    await span.waitFor({ state: 'visible' });
    const box = await span.boundingBox();
    await page.mouse.click(box.x + Math.min(box.width / 2, 6), box.y + box.height / 2);
  };
  await check('preview cursor lights instances and sweeps', async () => {
    await openFile('examples/icosahedron.mdg');
    await palette('MDG: Preview');
    const frame = await previewOf('icosahedron.mdg');
    const total = Number(await frame.locator('#status').getAttribute('data-triangles'));
    await clickIn('icosahedron.mdg', 'tetrahedron', 0);
    const own = await until('the tetrahedron’s spheres lit', async () => ((await litInstances(frame)) === 4 ? await lit(frame) : undefined), 15000);
    const ownLabel = await frame.locator('#hl').innerText();
    await clickIn('icosahedron.mdg', 'solids', 1);
    const all = await until('the whole model lit', async () => ((await lit(frame)) === total ? total : undefined), 15000);
    const spheres = await litInstances(frame);
    if (spheres !== 30) throw new Error(`${spheres} SPHERE instances lit for solids, expected 30`);
    await sleep(500);
    return `tetrahedron: ${ownLabel} (its 4 SPHEREs); solids: ${await frame.locator('#hl').innerText()} (${all} of ${total}, ${spheres} SPHEREs and the tubes)`;
  });

  // The derivation inspector: the tree of rule calls (solids → icosahedron,
  // tetrahedron, …), a click on a row lights what that path made, its place opens
  // the rule's definition, and the depth slider cuts the model (fewer triangles
  // drawn), then restores it.
  await check('preview derivation inspector', async () => {
    const frame = await previewOf('icosahedron.mdg');
    const status = frame.locator('#status');
    const total = Number(await status.getAttribute('data-triangles'));
    // The preview's group maximized, for the screenshots (restored at the end).
    await page.locator('.tab', { hasText: 'Preview icosahedron.mdg' }).first().click();
    await palette('View: Toggle Maximize Editor Group');
    await sleep(500);
    await frame.locator('#treebutton').click();
    const rows = frame.locator('#treelist .row');
    await rows.first().waitFor({ state: 'visible', timeout: 10000 });
    const names = await rows.evaluateAll((l) => l.map((e) => e.querySelector('.rule').textContent));
    if (names[0] !== 'solids' || !names.includes('tetrahedron') || !names.includes('poly_edge')) throw new Error(`rows: ${names}`);
    const tet = rows.filter({ has: frame.locator('.rule', { hasText: /^tetrahedron$/ }) }).first();
    await tet.click();
    const n = await until('the tetrahedron lit', async () => {
      const v = await lit(frame);
      return v > 0 && v < total && (await litInstances(frame)) === 4 ? v : undefined;
    }, 10000);
    const label = await frame.locator('#hl').innerText();
    await sleep(400);
    await shot('preview-inspector');
    // The depth slider: depth ≤ 1 (the solids' own spheres, not the tubes of
    // their poly_edge calls) draws fewer triangles; all again at the end.
    const depth = frame.locator('#depth');
    const max = Number(await depth.getAttribute('max'));
    if (!(max >= 2)) throw new Error(`depth slider max ${max}`);
    await depth.fill('1');
    const cut = await until('the model cut at depth 1', async () => {
      const v = Number((await status.getAttribute('data-drawn-triangles', { timeout: 1000 })) ?? -1);
      return v > 0 && v < total ? v : undefined;
    }, 10000);
    await sleep(400);
    await shot('preview-depth');
    await depth.fill(String(max));
    await until('the whole model again', async () => Number(await status.getAttribute('data-drawn-triangles')) === total, 10000);
    await page.locator('.tab', { hasText: 'Preview icosahedron.mdg' }).first().click();
    await palette('View: Toggle Maximize Editor Group');
    await sleep(500);
    // The place of a row opens the rule's definition (the `rule tetrahedron` line,
    // 40, of std/polyhedra.mdg).
    await tet.locator('.place').click();
    await page.locator('.tab.active[aria-label^="polyhedra.mdg"]').waitFor({ state: 'visible', timeout: 15000 });
    const where = await until('rule tetrahedron in the editor', async () => {
      const t = await page.locator('.statusbar-item[id="status.editor.selection"]').innerText({ timeout: 1000 }).catch(() => '');
      const text = (await page.locator('.editor-group-container.active .monaco-editor .view-lines').first().innerText()).replace(/\u00a0/g, ' ');
      return /Ln 40,/.test(t) && text.includes('rule tetrahedron') ? t : undefined;
    }, 10000);
    await frame.locator('#treebutton').click().catch(() => {});
    return `${names.length} rows; row tetrahedron: ${label} (of ${total}); depth ≤ 1 draws ${cut} of ${total} (slider 0..${max}); its place: polyhedra.mdg at ${where}`;
  });

} finally {
  fs.writeFileSync(resultsFile, JSON.stringify({ seconds: (Date.now() - t0) / 1000, checks: results }, null, 2));
  await browser.close().catch(() => {});
  server.kill();
  if (results.some((r) => !r.ok)) {
    console.log('--- code-server log ---\n' + serverLog.slice(-4000));
  }
}
log(`${results.filter((r) => r.ok).length}/${results.length} checks passed`);
process.exit(results.every((r) => r.ok) ? 0 : 1);
