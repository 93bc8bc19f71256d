// Unit tests of the extension's pure helpers: `node --test out/test/`.

import { test } from 'node:test';
import * as assert from 'node:assert/strict';
import { previewArgs, previewGlb, resolveProgram, resolveServerPath, runArgs } from '../paths';

test('server path: default, home, workspace-relative, PATH names, absolute', () => {
  assert.equal(resolveServerPath(undefined), 'mdg-lsp');
  assert.equal(resolveServerPath('  '), 'mdg-lsp');
  assert.equal(resolveServerPath('~/bin/mdg-lsp', undefined, '/home/u'), '/home/u/bin/mdg-lsp');
  assert.equal(resolveServerPath('target/debug/mdg-lsp', '/work/proj'), '/work/proj/target/debug/mdg-lsp');
  assert.equal(resolveServerPath('mdg-lsp-dev', '/work/proj'), 'mdg-lsp-dev');
  assert.equal(resolveServerPath('/opt/mdg/bin/mdg-lsp', '/work/proj'), '/opt/mdg/bin/mdg-lsp');
});

test('the live preview evaluates the editor text into a .glb in a temporary directory', () => {
  assert.equal(previewGlb('/a/b/tree.mdg', '0123abcd', '/tmp'), '/tmp/mdg-preview/tree-0123abcd.glb');
  assert.deepEqual(previewArgs('/a/b/tree.mdg', '/tmp/x.glb'), ['/a/b/tree.mdg', '--stdin', '-o', '/tmp/x.glb']);
});

test('code lenses run mdg-run on the saved file', () => {
  assert.deepEqual(runArgs('render', '/a/tree.mdg'), ['/a/tree.mdg', '-o', '/a/tree.glb', '--stats']);
  assert.deepEqual(runArgs('stats', '/a/tree.mdg', '/tmp'), ['/a/tree.mdg', '--stats', '-o', '/tmp/mdg-stats/tree.glb']);
  assert.deepEqual(runArgs('search', '/a/guided.mdg'), ['/a/guided.mdg', '--stats', '-o', '/a/guided.glb']);
  assert.deepEqual(runArgs('evolve', '/a/monsters.mdg'), ['/a/monsters.mdg', '--stats']);
});

test('a platform .vsix runs its own binaries unless a setting names others', () => {
  const there = (p: string) => p === '/ext/bin/mdg-lsp' || p === '/ext/bin/mdg-run';
  assert.equal(resolveProgram('mdg-lsp', '', '/ext', undefined, there), '/ext/bin/mdg-lsp');
  assert.equal(resolveProgram('mdg-run', 'mdg-run', '/ext', undefined, there), '/ext/bin/mdg-run');
  assert.equal(resolveProgram('mdg-lsp', 'target/debug/mdg-lsp', '/ext', '/w', there), '/w/target/debug/mdg-lsp');
  assert.equal(resolveProgram('mdg-lsp', '', '/other', undefined, there), 'mdg-lsp');
  assert.equal(resolveProgram('mdg-run', undefined, undefined, undefined, there), 'mdg-run');
});
