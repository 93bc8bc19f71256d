// Pure helpers of the extension (no `vscode` import), unit-tested with node:test.

import * as fs from 'fs';
import * as os from 'os';
import * as path from 'path';

/**
 * The command that starts the server, from the `mdg.serverPath` setting: empty
 * means `mdg-lsp` on PATH; `~/` is the home directory; a relative path with a
 * slash is relative to the workspace folder; a bare name is looked up on PATH.
 */
export function resolveServerPath(setting: string | undefined, workspaceRoot?: string, home: string = os.homedir()): string {
  const s = (setting ?? '').trim();
  if (s === '') {
    return 'mdg-lsp';
  }
  if (s === '~' || s.startsWith('~/')) {
    return path.join(home, s.slice(1));
  }
  if (path.isAbsolute(s) || !s.includes('/')) {
    return s;
  }
  return workspaceRoot ? path.join(workspaceRoot, s) : s;
}

/** Where the live preview of `file` writes its model: one `.glb` per source file
 * (`id` tells files of the same name apart) in a temporary directory. */
export function previewGlb(file: string, id: string, tmp: string = os.tmpdir()): string {
  const base = path.basename(file).replace(/\.mdg$/, '');
  return path.join(tmp, 'mdg-preview', `${base}-${id}.glb`);
}

/** A `@param` declaration as `mdg-run --params-json` writes it. */
export interface ParamDecl {
  name: string;
  type: 'int' | 'float' | 'bool';
  /** The value in force (the default or the override passed). */
  value: number;
  /** `null` where the `@param` line declares no range. */
  min: number | null;
  max: number | null;
}

/**
 * The arguments of `mdg-run` for the live preview: the editor's text on stdin;
 * with `paramsJson`, the `@param` declarations are written there, and each of
 * `values` (the sliders moved, by name) is passed as `--param NAME=V`, in name
 * order so that the same sliders give the same command.
 */
export function previewArgs(file: string, glb: string, paramsJson?: string, values: Record<string, number> = {}): string[] {
  // `--sites`: which rule drew each triangle, for a click on the model.
  const args = [file, '--stdin', '-o', glb, '--sites'];
  if (paramsJson !== undefined) {
    args.push('--params-json', paramsJson);
  }
  for (const name of Object.keys(values).sort()) {
    const v = values[name];
    if (Number.isFinite(v)) {
      args.push('--param', `${name}=${v}`);
    }
  }
  return args;
}

/**
 * Where the file a click on the model names may be (the bundle names the main
 * file by its base name, an import relative to the main file's folder, the std
 * library's files as `std/NAME`): the candidates in order, the first that exists
 * wins.
 */
export function siteCandidates(siteFile: string, docFile: string, stdDirs: string[]): string[] {
  if (siteFile === '') return [];
  if (siteFile === path.basename(docFile)) return [docFile];
  if (path.isAbsolute(siteFile)) return [siteFile];
  const out = [path.join(path.dirname(docFile), siteFile)];
  if (siteFile.startsWith('std/')) {
    for (const d of stdDirs) out.push(path.join(d, siteFile.slice(4)));
  }
  return out;
}

/**
 * The slider values still worth passing: those of parameters `declared` now (a
 * `@param` deleted or renamed in the editor drops its slider's value), ints
 * rounded, each clamped to its declared range.
 */
export function keptValues(values: Record<string, number>, declared: ParamDecl[]): Record<string, number> {
  const kept: Record<string, number> = {};
  for (const d of declared) {
    if (!(d.name in values)) continue;
    let v = values[d.name];
    if (d.type === 'int') v = Math.round(v);
    if (d.type === 'bool') v = v ? 1 : 0;
    if (d.min !== null && d.max !== null) v = Math.min(Math.max(v, Math.min(d.min, d.max)), Math.max(d.min, d.max));
    kept[d.name] = v;
  }
  return kept;
}

/**
 * A slider's range: the declared one; without one, the value's own scale around
 * it (0..2v for a positive value, 2v..0 for a negative one, 0..1 for zero). Ints
 * step by 1, floats by a power of ten with the value on the grid ([`floatStep`]).
 */
export function sliderRange(d: ParamDecl): { min: number; max: number; step: number } {
  let lo: number;
  let hi: number;
  if (d.min !== null && d.max !== null && d.min !== d.max) {
    lo = Math.min(d.min, d.max);
    hi = Math.max(d.min, d.max);
  } else if (d.value > 0) {
    lo = 0;
    hi = 2 * d.value;
  } else if (d.value < 0) {
    lo = 2 * d.value;
    hi = 0;
  } else {
    lo = 0;
    hi = 1;
  }
  if (d.type === 'bool') return { min: 0, max: 1, step: 1 };
  if (d.type === 'int') return { min: Math.floor(lo), max: Math.max(Math.ceil(hi), Math.floor(lo) + 1), step: 1 };
  return { min: lo, max: hi, step: floatStep(lo, hi, d.value) };
}

/** What a code lens runs with `mdg-run` on a saved file. */
export type RunKind = 'render' | 'stats' | 'search' | 'evolve';

/** The `.mdg` file's path with another ending: `tree.mdg` -> `tree.glb`. */
export function besides(file: string, ending: string): string {
  return file.replace(/\.mdg$/, '') + ending;
}

/**
 * The arguments of `mdg-run` for a code lens: **Render .glb** writes `FILE.glb`
 * beside the source; **Stats** prints the counters and writes the model to a
 * temporary directory; **Run search** runs the guided search into `FILE.glb`
 * beside the source; **Evolve** evolves the creature grammar into mdg-run's
 * default folder beside the source.
 */
export function runArgs(kind: RunKind, file: string, tmp: string = os.tmpdir()): string[] {
  switch (kind) {
    case 'render':
      return [file, '-o', besides(file, '.glb'), '--stats'];
    case 'stats':
      return [file, '--stats', '-o', path.join(tmp, 'mdg-stats', path.basename(besides(file, '.glb')))];
    case 'search':
      return [file, '--stats', '-o', besides(file, '.glb')];
    case 'evolve':
      return [file, '--stats'];
  }
}

/**
 * A program of a platform `.vsix` (`scripts/package-platform.sh` puts `mdg-lsp` and
 * `mdg-run` in the extension's `bin/`, with `std/` beside it): used when the setting
 * is left at its default (empty or the bare program name) and the file is there;
 * otherwise the setting, resolved as `resolveServerPath` does.
 */
export function resolveProgram(
  name: string,
  setting: string | undefined,
  extensionPath: string | undefined,
  workspaceRoot?: string,
  exists: (p: string) => boolean = (p) => fs.existsSync(p),
): string {
  const s = (setting ?? '').trim();
  if ((s === '' || s === name) && extensionPath) {
    const bundled = path.join(extensionPath, 'bin', process.platform === 'win32' ? `${name}.exe` : name);
    if (exists(bundled)) {
      return bundled;
    }
  }
  return s === '' ? name : resolveServerPath(s, workspaceRoot);
}

/**
 * A float slider's step: a power of ten about a hundredth of the range or finer,
 * the largest with the declared value on its grid (min + k·step), so the slider
 * shows 32 for 32 rather than the nearest hundredth of the range (31.95).
 */
function floatStep(lo: number, hi: number, value: number): number {
  let step = 10 ** Math.floor(Math.log10((hi - lo) / 100));
  for (let i = 0; i < 6; i++) {
    const k = (value - lo) / step;
    if (Math.abs(k - Math.round(k)) < 1e-6) return step;
    step /= 10;
  }
  return Number(step.toPrecision(1));
}

/**
 * How long the preview waits after a key before asking for the model: about as
 * long as the last evaluation took (a fast grammar previews as you type, a slow
 * one waits for a pause), within 10..400 ms; 150 ms before the first.
 */
export function adaptiveDebounce(lastMs: number | undefined): number {
  if (lastMs === undefined || !Number.isFinite(lastMs)) return 150;
  return Math.min(400, Math.max(10, Math.round(lastMs)));
}

const U64 = 1n << 64n;

/** The seed `delta` variations from `seed` (decimal u64, wrapping); undefined if `seed` is not one. */
export function stepSeed(seed: string, delta: number): string | undefined {
  if (!/^\d{1,20}$/.test(seed.trim())) return undefined;
  const n = BigInt(seed.trim());
  if (n >= U64) return undefined;
  return (((n + BigInt(delta)) % U64) + U64) % U64 + '';
}

/**
 * "Keep this variation": the line that makes `seed` the grammar's own — the
 * `randseed` directive replaced where there is one (its indent and comment
 * kept), else a new line after `startshape` (or at the top).
 */
export function randseedEdit(text: string, seed: string): { line: number; replace: boolean; text: string } {
  const lines = text.split('\n');
  for (let i = 0; i < lines.length; i++) {
    const m = /^(\s*)randseed\s+\S+(.*)$/.exec(lines[i]);
    if (m) return { line: i, replace: true, text: `${m[1]}randseed ${seed}${m[2]}` };
  }
  const start = lines.findIndex((l) => /^\s*startshape\b/.test(l));
  return { line: start >= 0 ? start + 1 : 0, replace: false, text: `randseed ${seed}` };
}

/**
 * The line (0-based) of `rule NAME` at or above line `from`, for a rule's
 * definition: the bundle knows a definition's first op's line, the reader wants
 * its header. `NAME` may be namespaced (`ns.leaf`: the header says `leaf`).
 * Looks at most 200 lines up; `from` when none is found.
 */
export function ruleHeaderLine(lineAt: (i: number) => string, from: number, rule: string): number {
  const short = rule.split('.').pop() ?? rule;
  if (short === '') return from;
  const escaped = short.replace(/[.*+?^${}()|[\]\\]/g, '\\$&');
  const header = new RegExp(`^\\s*rule\\s+${escaped}(?![A-Za-z0-9_])`);
  for (let i = from; i >= 0 && i >= from - 200; i--) {
    if (header.test(lineAt(i))) return i;
  }
  return from;
}
