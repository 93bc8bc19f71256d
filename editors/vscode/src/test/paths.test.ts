// Unit tests of the extension's pure helpers: `node --test out/test/`.

import { test } from 'node:test';
import * as assert from 'node:assert/strict';
import { adaptiveDebounce, keptValues, ParamDecl, previewArgs, previewGlb, randseedEdit, resolveProgram, ruleHeaderLine, resolveServerPath, runArgs, siteCandidates, sliderRange, stepSeed } from '../paths';

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
  assert.deepEqual(previewArgs('/a/b/tree.mdg', '/tmp/x.glb'), ['/a/b/tree.mdg', '--stdin', '-o', '/tmp/x.glb', '--sites']);
});

test('the preview passes the moved sliders as --param, in name order, and asks for the declarations', () => {
  assert.deepEqual(previewArgs('/a/t.mdg', '/tmp/x.glb', '/tmp/x.json'), ['/a/t.mdg', '--stdin', '-o', '/tmp/x.glb', '--sites', '--params-json', '/tmp/x.json']);
  assert.deepEqual(previewArgs('/a/t.mdg', '/tmp/x.glb', '/tmp/x.json', { spread: 12.5, levels: 3, bad: NaN }), [
    '/a/t.mdg', '--stdin', '-o', '/tmp/x.glb', '--sites', '--params-json', '/tmp/x.json', '--param', 'levels=3', '--param', 'spread=12.5',
  ]);
});

test('slider values: only declared parameters, ints rounded, clamped to the range', () => {
  const declared: ParamDecl[] = [
    { name: 'levels', type: 'int', value: 5, min: 1, max: 7 },
    { name: 'spread', type: 'float', value: 32, min: 5, max: 60 },
    { name: 'leafy', type: 'bool', value: 1, min: null, max: null },
  ];
  assert.deepEqual(keptValues({ levels: 9.4, spread: 7.25, gone: 3, leafy: 0 }, declared), { levels: 7, spread: 7.25, leafy: 0 });
  assert.deepEqual(keptValues({ levels: 2.6 }, declared), { levels: 3 });
});

test('slider ranges: declared, or around the value; ints step by one', () => {
  assert.deepEqual(sliderRange({ name: 'n', type: 'int', value: 5, min: 1, max: 7 }), { min: 1, max: 7, step: 1 });
  assert.deepEqual(sliderRange({ name: 'f', type: 'float', value: 1.5, min: 0.5, max: 2.5 }), { min: 0.5, max: 2.5, step: 0.01 });
  assert.deepEqual(sliderRange({ name: 'f', type: 'float', value: -2, min: null, max: null }), { min: -4, max: 0, step: 0.01 });
  // The declared value is on the slider's grid: 32 in 5..60 shows 32, not 31.95.
  const spread = sliderRange({ name: 'spread', type: 'float', value: 32, min: 5, max: 60 });
  assert.equal(spread.step, 0.1);
  const k = (32 - spread.min) / spread.step;
  assert.ok(Math.abs(k - Math.round(k)) < 1e-9, `32 is ${k} steps from 5`);
  // A value off every decimal grid gets the finest step tried.
  assert.equal(sliderRange({ name: 'p', type: 'float', value: Math.PI, min: 0, max: 10 }).step, 1e-7);
  assert.deepEqual(sliderRange({ name: 'n', type: 'int', value: 0, min: null, max: null }), { min: 0, max: 1, step: 1 });
  assert.deepEqual(sliderRange({ name: 'b', type: 'bool', value: 1, min: null, max: null }), { min: 0, max: 1, step: 1 });
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

test('a clicked site names the open file, an import beside it, or a std file', () => {
  assert.deepEqual(siteCandidates('tree.mdg', '/w/ex/tree.mdg', ['/std']), ['/w/ex/tree.mdg']);
  assert.deepEqual(siteCandidates('lib/leaf.mdg', '/w/ex/tree.mdg', ['/std']), ['/w/ex/lib/leaf.mdg']);
  assert.deepEqual(siteCandidates('std/primitives.mdg', '/w/ex/tree.mdg', ['/s1', '/s2']), [
    '/w/ex/std/primitives.mdg', '/s1/primitives.mdg', '/s2/primitives.mdg',
  ]);
  assert.deepEqual(siteCandidates('', '/w/ex/tree.mdg', ['/std']), []);
});

test('the preview waits after a key about as long as the grammar took, within 10..400 ms', () => {
  assert.equal(adaptiveDebounce(undefined), 150);
  assert.equal(adaptiveDebounce(3), 10);
  assert.equal(adaptiveDebounce(42.4), 42);
  assert.equal(adaptiveDebounce(5000), 400);
  assert.equal(adaptiveDebounce(NaN), 150);
});

test('variations: the next and previous seed, wrapping at the ends of u64', () => {
  assert.equal(stepSeed('0', 1), '1');
  assert.equal(stepSeed('41', -1), '40');
  assert.equal(stepSeed('0', -1), '18446744073709551615');
  assert.equal(stepSeed('18446744073709551615', 1), '0');
  assert.equal(stepSeed('9007199254740993', 1), '9007199254740994');
  assert.equal(stepSeed('nonsense', 1), undefined);
});

test('keep: the seed written as the randseed directive (replaced, else after startshape)', () => {
  assert.deepEqual(randseedEdit('startshape a\nrandseed 3\nrule a {}\n', '17'), { line: 1, replace: true, text: 'randseed 17' });
  assert.deepEqual(randseedEdit('  randseed   3 // old\n', '5'), { line: 0, replace: true, text: '  randseed 5 // old' });
  assert.deepEqual(randseedEdit('// tree\nstartshape a\nrule a {}\n', '9'), { line: 2, replace: false, text: 'randseed 9' });
  assert.deepEqual(randseedEdit('rule a {}\n', '9'), { line: 0, replace: false, text: 'randseed 9' });
  // A randseed inside a comment is not the directive.
  assert.deepEqual(randseedEdit('// randseed 4\nstartshape a\n', '1'), { line: 2, replace: false, text: 'randseed 1' });
});

test('ruleHeaderLine finds the rule NAME line at or above a definition op', () => {
  const lines = ['startshape a', 'rule a {', '  leaf {}', '}', 'rule leaf 0.5 {', '  VERTEX {}', '  VERTEX {x 1}', '}', 'rule leafy {', '  x {}'];
  const at = (i: number) => lines[i];
  assert.equal(ruleHeaderLine(at, 6, 'leaf'), 4);
  assert.equal(ruleHeaderLine(at, 6, 'ns.leaf'), 4);
  assert.equal(ruleHeaderLine(at, 4, 'leaf'), 4);
  // `leafy` is not `leaf`; none found: the line itself.
  assert.equal(ruleHeaderLine(at, 9, 'leaf'), 4);
  assert.equal(ruleHeaderLine(at, 2, 'leaf'), 2);
  assert.equal(ruleHeaderLine(at, 3, ''), 3);
});
