// The OpenAPI document validated by a standard validator (npm @apidevtools/swagger-parser:
// the OpenAPI 3.1 schema, $refs resolved, operation ids unique, path parameters declared).
// Usage: node openapi_validate.mjs docs/openapi.json
import SwaggerParser from "@apidevtools/swagger-parser";

const file = process.argv[2];
try {
  const api = await SwaggerParser.validate(file);
  const operations = Object.values(api.paths).reduce((n, item) => n + Object.keys(item).length, 0);
  console.log(`${file}: valid OpenAPI ${api.openapi}, ${Object.keys(api.paths).length} paths, ${operations} operations`);
} catch (e) {
  console.error(`FAIL: ${file}: ${e.message}`);
  process.exit(1);
}
