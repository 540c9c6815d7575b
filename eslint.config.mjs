// SPDX-License-Identifier: AGPL-3.0-or-later
// eslint.config.mjs - ESLint flat config for the portal's own scripts,
// web/*.js (browser ES modules); the vendored three.js is not linted.
// Run by tests/web/test_lint.py in `make test`.
import js from "@eslint/js";

const browser = Object.fromEntries([
  "window", "document", "location", "sessionStorage", "fetch", "XMLHttpRequest", "URL",
  "URLSearchParams", "TextDecoder", "AbortController", "setTimeout", "clearTimeout", "console",
  "Blob", "DataView", "Float32Array",
].map((n) => [n, "readonly"]));

export default [
  { ignores: ["web/vendor/**", "node_modules/**", "build*/**", "tests/**"] },
  js.configs.recommended,
  {
    files: ["web/*.js"],
    languageOptions: { ecmaVersion: 2022, sourceType: "module", globals: browser },
    rules: {
      "no-unused-vars": ["error", { args: "none", caughtErrors: "none" }],
      "no-implicit-globals": "error",
      "no-eval": "error",
      "no-implied-eval": "error",
      "no-new-func": "error",
      "no-restricted-properties": ["error",
        { property: "innerHTML", message: "set text with textContent (no HTML injection)" },
        { property: "outerHTML", message: "set text with textContent (no HTML injection)" },
        { property: "insertAdjacentHTML", message: "build nodes with the DOM" }],
      "eqeqeq": "error",
      "prefer-const": "error",
    },
  },
];
