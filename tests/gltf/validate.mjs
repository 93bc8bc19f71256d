// Validates .glb files with the Khronos glTF validator.
// Usage: node tests/gltf/validate.mjs FILE.glb [FILE.glb ...]
// Prints the error / warning / info counts per file, every error and warning
// message and the infos' codes with their counts; exits 1 if any file has errors
// (warnings and infos are reported, not fatal).
import fs from 'node:fs';
import validator from 'gltf-validator';

const MAX_SHOWN = 20;
const files = process.argv.slice(2);
if (files.length === 0) {
  console.error('usage: node validate.mjs FILE.glb [FILE.glb ...]');
  process.exit(2);
}

let failed = false;
for (const path of files) {
  let report;
  try {
    report = await validator.validateBytes(new Uint8Array(fs.readFileSync(path)), {
      maxIssues: 0,
      // Report only; the exporter never references external resources.
      externalResourceFunction: (uri) => Promise.reject(new Error(`external resource ${uri}`)),
    });
  } catch (e) {
    console.log(`${path}: validator failed: ${e && e.message ? e.message : e}`);
    failed = true;
    continue;
  }
  const issues = report.issues;
  console.log(`${path}: ${issues.numErrors} errors, ${issues.numWarnings} warnings, ${issues.numInfos} infos`);
  // severity: 0 error, 1 warning, 2 info, 3 hint. Errors first; at most MAX_SHOWN lines.
  const shown = issues.messages.filter((m) => m.severity <= 1).sort((a, b) => a.severity - b.severity);
  for (const m of shown.slice(0, MAX_SHOWN)) {
    const kind = m.severity === 0 ? 'error' : 'warning';
    console.log(`  ${kind} ${m.code}: ${m.message}${m.pointer ? ` (${m.pointer})` : ''}`);
  }
  if (shown.length > MAX_SHOWN) console.log(`  ... and ${shown.length - MAX_SHOWN} more`);
  const infos = {};
  for (const m of issues.messages.filter((m) => m.severity === 2)) infos[m.code] = (infos[m.code] ?? 0) + 1;
  if (Object.keys(infos).length > 0) {
    console.log(`  infos: ${Object.entries(infos).map(([code, n]) => `${code} ×${n}`).join(', ')}`);
  }
  if (issues.numErrors > 0) failed = true;
}
process.exit(failed ? 1 : 0);
