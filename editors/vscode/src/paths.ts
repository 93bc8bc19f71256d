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

/** The arguments of `mdg-run` for the live preview: the editor's text on stdin. */
export function previewArgs(file: string, glb: string): string[] {
  return [file, '--stdin', '-o', glb];
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
