// Every fixture's glTF output, default and at a tenth of its faces, and a mesh with colours,
// normals and texture coordinates: Khronos's glTF validator finds no error and no warning, and
// the Draco primitive, decoded by draco3d (not the library that wrote it), has the counts the
// accessors and gaussmesh's report give, the attributes the extension names, and POSITION's
// min/max. (The validator cannot look inside KHR_draco_mesh_compression: the decoding does.)
import fs from 'node:fs';
import path from 'node:path';
import { check, decodeDraco, finish, options, requireModules, scratch, simplify, writeAttributedTorus } from './support.mjs';

const { gaussmesh, modules, root } = options();
const { 'gltf-validator': validator, draco3d } = requireModules(modules, ['gltf-validator', 'draco3d']);
const decoderModule = await draco3d.createDecoderModule({});
const dir = scratch();

// The JSON and the binary buffer of a .glb or .gltf.
function open(file) {
  const bytes = fs.readFileSync(file);
  if (file.endsWith('.gltf')) {
    const document = JSON.parse(bytes.toString('utf8'));
    const uri = document.buffers[0].uri;
    const prefix = 'data:application/octet-stream;base64,';
    check(uri.startsWith(prefix), `${file}: the buffer is a base64 data URI`);
    return { document, bin: Buffer.from(uri.slice(prefix.length), 'base64') };
  }
  const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  check(bytes.subarray(0, 4).toString('latin1') === 'glTF' && view.getUint32(4, true) === 2, `${file}: a GLB 2 header`);
  const jsonLength = view.getUint32(12, true);
  const document = JSON.parse(bytes.subarray(20, 20 + jsonLength).toString('utf8'));
  const binLength = view.getUint32(20 + jsonLength, true);
  return { document, bin: bytes.subarray(28 + jsonLength, 28 + jsonLength + binLength) };
}

const kSemantics = { POSITION: 'POSITION', NORMAL: 'NORMAL', COLOR: 'COLOR_0', TEX_COORD: 'TEXCOORD_0' };

async function verify(file, report, expectedSemantics) {
  const bytes = fs.readFileSync(file);
  const validation = await validator.validateBytes(new Uint8Array(bytes), { uri: path.basename(file) });
  const problems = validation.issues.messages.filter((m) => m.severity <= 1);
  check(validation.issues.numErrors === 0 && validation.issues.numWarnings === 0,
    `${file}: validator: ${validation.issues.numErrors} errors, ${validation.issues.numWarnings} warnings ${JSON.stringify(problems.slice(0, 3))}`);

  const { document, bin } = open(file);
  check(JSON.stringify(document.extensionsRequired) === '["KHR_draco_mesh_compression"]', `${file}: Draco required`);
  const primitive = document.meshes[0].primitives[0];
  const extension = primitive.extensions.KHR_draco_mesh_compression;
  const view = document.bufferViews[extension.bufferView];
  const draco = bin.subarray(view.byteOffset ?? 0, (view.byteOffset ?? 0) + view.byteLength);
  const decoded = decodeDraco(decoderModule, draco);
  if (!check(decoded.ok, `${file}: draco3d decodes the primitive (${decoded.error})`)) return;

  const faces = report.output_faces;
  check(decoded.faces.length === faces, `${file}: ${decoded.faces.length} decoded faces, the report says ${faces}`);
  check(document.accessors[primitive.indices].count === 3 * faces, `${file}: the indices accessor counts 3 per face`);
  check(decoded.faces.every((f) => f.every((v) => v >= 0 && v < decoded.points)), `${file}: every index names a point`);
  check(JSON.stringify(Object.keys(primitive.attributes).sort()) === JSON.stringify([...expectedSemantics].sort()),
    `${file}: attributes ${Object.keys(primitive.attributes)} (expected ${expectedSemantics})`);
  for (const [semantic, accessorIndex] of Object.entries(primitive.attributes)) {
    const accessor = document.accessors[accessorIndex];
    check(accessor.count === decoded.points, `${file}: ${semantic} counts ${accessor.count}, Draco has ${decoded.points} points`);
    const attribute = decoded.byUniqueId.get(extension.attributes[semantic]);
    if (!check(attribute !== undefined, `${file}: the extension's ${semantic} id names a Draco attribute`)) continue;
    const typeName = Object.keys(kSemantics).find((k) => decoderModule[k] === attribute.type);
    check(kSemantics[typeName] === semantic, `${file}: ${semantic} is Draco's ${typeName}`);
    if (semantic === 'POSITION') {
      const lo = [Infinity, Infinity, Infinity];
      const hi = [-Infinity, -Infinity, -Infinity];
      attribute.values.forEach((value, k) => {
        lo[k % 3] = Math.min(lo[k % 3], value);
        hi[k % 3] = Math.max(hi[k % 3], value);
      });
      const same = (a, b) => a.every((x, k) => Math.fround(x) === Math.fround(b[k]));
      check(same(accessor.min, lo) && same(accessor.max, hi), `${file}: POSITION min/max ${accessor.min}/${accessor.max} against ${lo}/${hi}`);
    }
  }
}

let outputs = 0;
const fixtures = fs.readdirSync(path.join(root, 'fixtures/real')).filter((f) => /\.(off|ply)$/.test(f)).sort();
for (const fixture of fixtures) {
  const input = path.join(root, 'fixtures/real', fixture);
  for (const [name, args] of [['plain', []], ['tenth', ['--ratio', '0.1']]]) {
    const output = path.join(dir, `${fixture}-${name}.glb`);
    await verify(output, simplify(gaussmesh, input, output, args), ['POSITION']);
    outputs += 1;
  }
}
const torus = path.join(dir, 'torus.ply');
writeAttributedTorus(torus, 120, 60);
for (const extension of ['glb', 'gltf']) {
  const output = path.join(dir, `torus.${extension}`);
  await verify(output, simplify(gaussmesh, torus, output, ['--ratio', '0.05']), ['POSITION', 'NORMAL', 'COLOR_0', 'TEXCOORD_0']);
  outputs += 1;
}
finish(`${outputs} glTF outputs of ${fixtures.length} fixtures and an attributed torus`);
