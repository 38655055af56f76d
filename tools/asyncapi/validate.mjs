// Validate an AsyncAPI document with the AsyncAPI parser (make test; tests/api/test_asyncapi.py).
// Usage: node tools/asyncapi/validate.mjs openapi/asyncapi.json
// Prints every diagnostic as one JSON line; exits 1 on any error or warning.
import { readFileSync } from 'node:fs';
import { Parser } from '@asyncapi/parser';

const path = process.argv[2];
const parser = new Parser();
const { document, diagnostics } = await parser.parse(readFileSync(path, 'utf8'));
const severities = ['error', 'warning', 'info', 'hint'];
for (const d of diagnostics) {
  console.log(JSON.stringify({
    severity: severities[d.severity], code: d.code, message: d.message, path: d.path.join('/'),
  }));
}
const bad = diagnostics.filter((d) => d.severity <= 1);
if (!document || bad.length) {
  console.error(`${path}: ${bad.length} error(s)/warning(s)`);
  process.exit(1);
}
console.log(JSON.stringify({
  valid: path, version: document.version(), operations: document.operations().length,
  messages: document.allMessages().length,
}));
