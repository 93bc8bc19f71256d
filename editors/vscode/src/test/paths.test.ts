// Unit tests of the extension's pure helpers: `node --test out/test/`.

import { test } from 'node:test';
import * as assert from 'node:assert/strict';
import { previewOutputs, resolveServerPath, runArgs } from '../paths';

test('server path: default, home, workspace-relative, PATH names, absolute', () => {
  assert.equal(resolveServerPath(undefined), 'mdg-lsp');
  assert.equal(resolveServerPath('  '), 'mdg-lsp');
  assert.equal(resolveServerPath('~/bin/mdg-lsp', undefined, '/home/u'), '/home/u/bin/mdg-lsp');
  assert.equal(resolveServerPath('target/debug/mdg-lsp', '/work/proj'), '/work/proj/target/debug/mdg-lsp');
  assert.equal(resolveServerPath('mdg-lsp-dev', '/work/proj'), 'mdg-lsp-dev');
  assert.equal(resolveServerPath('/opt/mdg/bin/mdg-lsp', '/work/proj'), '/opt/mdg/bin/mdg-lsp');
});

test('preview fallback writes beside each other in a temporary directory', () => {
  const o = previewOutputs('/a/b/tree.mdg', '/tmp');
  assert.deepEqual(o, { dir: '/tmp/mdg-preview', glb: '/tmp/mdg-preview/tree.glb', png: '/tmp/mdg-preview/tree.png' });
  assert.deepEqual(runArgs('/a/b/tree.mdg', o), ['/a/b/tree.mdg', '-o', '/tmp/mdg-preview/tree.glb', '--png', '/tmp/mdg-preview/tree.png']);
});
