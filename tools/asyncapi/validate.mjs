// Validate an AsyncAPI document with the AsyncAPI parser (make test; tests/api/test_asyncapi.py).
// Usage: node tools/asyncapi/validate.mjs openapi/asyncapi.json [more.json ...]
// Prints every diagnostic as one JSON line (with its file), then one summary line per file:
// {"file", "valid", ...}. Exits 1 when any file has an error or a warning.
import { readFileSync } from 'node:fs';
import { Parser } from '@asyncapi/parser';

const parser = new Parser();
const severities = ['error', 'warning', 'info', 'hint'];
let failed = false;
for (const file of process.argv.slice(2)) {
  const { document, diagnostics } = await parser.parse(readFileSync(file, 'utf8'));
  for (const d of diagnostics) {
    console.log(JSON.stringify({
      file, severity: severities[d.severity], code: d.code, message: d.message,
      path: d.path.join('/'),
    }));
  }
  const bad = diagnostics.filter((d) => d.severity <= 1);
  const valid = Boolean(document) && bad.length === 0;
  failed ||= !valid;
  console.log(JSON.stringify(valid ? {
    file, valid, version: document.version(), operations: document.operations().length,
    messages: document.allMessages().length,
  } : { file, valid, problems: bad.length }));
}
process.exit(failed ? 1 : 0);
