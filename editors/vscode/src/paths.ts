// Pure helpers of the extension (no `vscode` import), unit-tested with node:test.

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

/** Where the PNG fallback of "MDG: Preview" writes for `file`: a mesh and a picture in a temporary directory. */
export function previewOutputs(file: string, tmp: string = os.tmpdir()): { dir: string; glb: string; png: string } {
  const dir = path.join(tmp, 'mdg-preview');
  const base = path.basename(file).replace(/\.mdg$/, '');
  return { dir, glb: path.join(dir, `${base}.glb`), png: path.join(dir, `${base}.png`) };
}

/** The arguments of `mdg-run` for the PNG fallback. */
export function runArgs(file: string, outputs: { glb: string; png: string }): string[] {
  return [file, '-o', outputs.glb, '--png', outputs.png];
}
