// The Khronos glTF validator on the asset output of files as tools write them: the textured room
// (Blender's glTF exporter: textures, a second UV set, an alpha-masked lattice, emissive
// textures) baked with --lightmap-uv generate and asset, and the instanced, strip-drawn file of
// tests/io (through its scene). Each must validate with 0 errors and keep every material,
// texture, image and node of its input.
//
//   node tests/web/validate_test.mjs PENUMBRA_CLI REPO_ROOT WORK_DIR
//
// Exit codes: 0 pass, 1 fail, 77 skip (web/node_modules missing and PENUMBRA_REQUIRE_BROWSER
// is not 1).

import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import { createRequire } from 'node:module';
import path from 'node:path';

const [cli, root, workDir] = process.argv.slice(2).map((a) => (a ? path.resolve(a) : a));

function log(message) {
  process.stdout.write(`${message}\n`);
}

function glbJson(file) {
  const bytes = fs.readFileSync(file);
  if (bytes.toString('latin1', 0, 4) !== 'glTF') return JSON.parse(bytes.toString('utf8'));
  const length = bytes.readUInt32LE(12);
  return JSON.parse(bytes.toString('utf8', 20, 20 + length));
}

// JSON with every object's keys sorted, so that key order does not count.
function canonical(value) {
  if (Array.isArray(value)) return `[${value.map(canonical).join(',')}]`;
  if (value && typeof value === 'object') {
    return `{${Object.keys(value).sort().map((k) => `${JSON.stringify(k)}:${canonical(value[k])}`).join(',')}}`;
  }
  return JSON.stringify(value);
}

async function validate(validator, file) {
  const dir = path.dirname(file);
  const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
    uri: path.basename(file),
    maxIssues: 0,
    externalResourceFunction: (uri) =>
      fs.promises.readFile(path.join(dir, decodeURIComponent(uri))).then((d) => new Uint8Array(d)),
  });
  const { numErrors, numWarnings, numInfos, messages } = report.issues;
  log(`${path.relative(workDir, file)}: ${numErrors} errors, ${numWarnings} warnings, ` +
      `${numInfos} infos`);
  for (const m of messages.filter((m) => m.severity <= 1).slice(0, 10)) {
    log(`  ${m.severity === 0 ? 'error' : 'warning'} ${m.code} at ${m.pointer ?? '-'}: ${m.message}`);
  }
  return numErrors;
}

async function main() {
  const webDir = path.join(root, 'web');
  if (!fs.existsSync(path.join(webDir, 'node_modules', 'gltf-validator', 'package.json'))) {
    const message = 'missing web/node_modules/gltf-validator: run scripts/install-deps.sh';
    if (process.env.PENUMBRA_REQUIRE_BROWSER === '1') {
      log(`FAIL: ${message} (PENUMBRA_REQUIRE_BROWSER=1)`);
      return 1;
    }
    log(`SKIP: ${message}`);
    return 77;
  }
  const validator = createRequire(path.join(webDir, 'package.json'))('gltf-validator');
  fs.rmSync(workDir, { recursive: true, force: true });
  fs.mkdirSync(workDir, { recursive: true });
  const room = path.join(root, 'scenes', 'textured_room', 'room.glb');
  const input = glbJson(room);
  let failures = 0;
  for (const uv of ['generate', 'asset']) {
    const out = path.join(workDir, uv);
    const r = spawnSync(cli, ['bake', room, '--method', 'progressive', '--texel-density', '5',
                              '--lightmap-uv', uv, '--quiet', '-o', out], { encoding: 'utf8' });
    if (r.status !== 0) {
      log(`FAIL: bake --lightmap-uv ${uv} exited ${r.status}: ${r.stderr}`);
      return 1;
    }
    const gltf = path.join(out, 'room.gltf');
    failures += await validate(validator, gltf);
    const baked = JSON.parse(fs.readFileSync(gltf, 'utf8'));
    for (const key of ['materials', 'textures', 'images', 'samplers', 'nodes']) {
      for (let i = 0; i < input[key].length; ++i) {
        const want = structuredClone(input[key][i]);
        const got = structuredClone(baked[key][i]);
        if (key === 'materials' && got.extensions) {
          delete got.extensions.PENUMBRA_lightmap;
          if (Object.keys(got.extensions).length === 0) delete got.extensions;
        }
        if (canonical(got) !== canonical(want)) {
          log(`FAIL: --lightmap-uv ${uv}: ${key}[${i}] differs from the input's`);
          ++failures;
        }
      }
    }
  }
  log(failures ? `FAIL: ${failures} problems` : 'PASS');
  return failures ? 1 : 0;
}

main().then((code) => process.exit(code), (e) => {
  log(`FAIL: ${e.stack ?? e}`);
  process.exit(1);
});
