// Shared by the web tests (tests/web/*.mjs): where things are, running gaussmesh, the npm
// packages, Draco decoding with draco3d, and small mesh files written and read here.
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import { createRequire } from 'node:module';
import os from 'node:os';
import path from 'node:path';

// Exit status ctest reads as "skipped" (SKIP_RETURN_CODE in tests/CMakeLists.txt).
export const kSkipped = 77;

// --gaussmesh BIN --modules DIR --root DIR, from tests/CMakeLists.txt.
export function options() {
  const args = process.argv.slice(2);
  const value = (name) => {
    const at = args.indexOf(name);
    return at >= 0 ? args[at + 1] : undefined;
  };
  return { gaussmesh: value('--gaussmesh'), modules: value('--modules'), root: value('--root') };
}

// The packages of tests/web/package.json, as scripts/bootstrap test installs them; without
// them the test says so and is skipped.
export function requireModules(dir, names) {
  const missing = names.filter((name) => !fs.existsSync(path.join(dir, name, 'package.json')));
  if (missing.length > 0) {
    console.log(`SKIPPED: npm packages ${missing.join(', ')} not installed in ${dir} (scripts/bootstrap test installs them)`);
    process.exit(kSkipped);
  }
  const require = createRequire(path.join(path.resolve(dir), 'index.js'));
  return Object.fromEntries(names.map((name) => [name, require(name)]));
}

let failures = 0;
export function check(condition, message) {
  if (!condition) {
    failures += 1;
    console.log(`FAILED: ${message}`);
  }
  return condition;
}
export function finish(what) {
  if (failures > 0) {
    console.log(`${failures} check(s) failed`);
    process.exit(1);
  }
  console.log(`passed: ${what}`);
}

export function scratch() {
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'gaussmesh-web-test-'));
  process.on('exit', () => fs.rmSync(dir, { recursive: true, force: true }));
  return dir;
}

// Runs gaussmesh simplify INPUT -o OUTPUT ARGS... and returns its JSON report.
export function simplify(gaussmesh, input, output, args = []) {
  const report = `${output}.json`;
  execFileSync(gaussmesh, ['simplify', input, '-o', output, '--report', report, ...args], { stdio: ['ignore', 'ignore', 'pipe'] });
  return JSON.parse(fs.readFileSync(report, 'utf8'));
}

// A closed bumpy torus grid (n x m vertices) as ASCII PLY, each vertex with a colour that is a
// function of its position, a normal and texture coordinates.
export function writeAttributedTorus(file, n, m) {
  const vertices = [];
  for (let i = 0; i < n; i += 1) {
    for (let j = 0; j < m; j += 1) {
      const u = (2 * Math.PI * i) / n;
      const v = (2 * Math.PI * j) / m;
      const r = 1 + 0.1 * Math.sin(5 * u) * Math.cos(3 * v);
      const x = (3 + r * Math.cos(v)) * Math.cos(u);
      const y = (3 + r * Math.cos(v)) * Math.sin(u);
      const z = r * Math.sin(v);
      const colour = [x, y, z].map((c, k) => Math.round(255 * (0.5 + 0.5 * Math.sin(0.7 * c + k))));
      const normal = [Math.cos(v) * Math.cos(u), Math.cos(v) * Math.sin(u), Math.sin(v)];
      vertices.push(`${x} ${y} ${z} ${normal.join(' ')} ${colour.join(' ')} ${i / n} ${j / m}`);
    }
  }
  const id = (i, j) => (i % n) * m + (j % m);
  const faces = [];
  for (let i = 0; i < n; i += 1) {
    for (let j = 0; j < m; j += 1) {
      faces.push(`3 ${id(i, j)} ${id(i + 1, j)} ${id(i + 1, j + 1)}`);
      faces.push(`3 ${id(i, j)} ${id(i + 1, j + 1)} ${id(i, j + 1)}`);
    }
  }
  const header = ['ply', 'format ascii 1.0', `element vertex ${vertices.length}`, 'property float x', 'property float y',
    'property float z', 'property float nx', 'property float ny', 'property float nz', 'property uchar red',
    'property uchar green', 'property uchar blue', 'property float s', 'property float t',
    `element face ${faces.length}`, 'property list uchar int vertex_indices', 'end_header'];
  fs.writeFileSync(file, `${header.join('\n')}\n${vertices.join('\n')}\n${faces.join('\n')}\n`);
}

// Decodes Draco bytes with draco3d: counts, and per attribute its values for every point
// (floats, or bytes for 8-bit colours), by draco3d's attribute type name.
export function decodeDraco(module, bytes) {
  const decoder = new module.Decoder();
  const buffer = new module.DecoderBuffer();
  buffer.Init(new Int8Array(bytes.buffer, bytes.byteOffset, bytes.byteLength), bytes.byteLength);
  const mesh = new module.Mesh();
  const status = decoder.DecodeBufferToMesh(buffer, mesh);
  const result = { ok: status.ok(), error: status.error_msg(), points: 0, faces: [], byUniqueId: new Map() };
  if (result.ok) {
    result.points = mesh.num_points();
    const face = new module.DracoInt32Array();
    for (let f = 0; f < mesh.num_faces(); f += 1) {
      decoder.GetFaceFromMesh(mesh, f, face);
      result.faces.push([face.GetValue(0), face.GetValue(1), face.GetValue(2)]);
    }
    module.destroy(face);
    for (let a = 0; a < mesh.num_attributes(); a += 1) {
      const attribute = decoder.GetAttribute(mesh, a);
      const components = attribute.num_components();
      const isColour = attribute.attribute_type() === module.COLOR;
      const array = isColour ? new module.DracoUInt8Array() : new module.DracoFloat32Array();
      if (isColour) decoder.GetAttributeUInt8ForAllPoints(mesh, attribute, array);
      else decoder.GetAttributeFloatForAllPoints(mesh, attribute, array);
      const values = [];
      for (let k = 0; k < array.size(); k += 1) values.push(array.GetValue(k));
      module.destroy(array);
      result.byUniqueId.set(attribute.unique_id(), { type: attribute.attribute_type(), components, values });
    }
  }
  module.destroy(mesh);
  module.destroy(buffer);
  module.destroy(decoder);
  return result;
}

// A binary little-endian PLY as draco_decoder writes one: each vertex property's values in
// vertex order, and per face its corners and, when present, its corners' texture coordinates
// (draco_decoder writes those per face, as "property list uchar float texcoord").
export function readDracoDecoderPly(file) {
  const bytes = fs.readFileSync(file);
  const end = bytes.indexOf('end_header\n');
  const header = bytes.subarray(0, end).toString('latin1').split('\n');
  if (!header.includes('format binary_little_endian 1.0')) throw new Error(`${file}: not binary little-endian PLY`);
  const elements = [];
  for (const line of header) {
    const words = line.trim().split(/\s+/);
    if (words[0] === 'element') elements.push({ name: words[1], count: Number(words[2]), properties: [] });
    if (words[0] === 'property') {
      const list = words[1] === 'list';
      elements.at(-1).properties.push(list ? { list: true, countType: words[2], type: words[3], name: words[4] } : { type: words[1], name: words[2] });
    }
  }
  const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  let at = end + 'end_header\n'.length;
  const read = (type) => {
    let value;
    if (type === 'uchar' || type === 'uint8') value = view.getUint8(at), at += 1;
    else if (type === 'float' || type === 'float32') value = view.getFloat32(at, true), at += 4;
    else if (type === 'int' || type === 'int32') value = view.getInt32(at, true), at += 4;
    else throw new Error(`${file}: property type ${type}`);
    return value;
  };
  const result = {};
  for (const element of elements) {
    const columns = Object.fromEntries(element.properties.map((p) => [p.name, []]));
    for (let i = 0; i < element.count; i += 1) {
      for (const p of element.properties) {
        if (p.list) {
          const n = read(p.countType);
          const values = [];
          for (let k = 0; k < n; k += 1) values.push(read(p.type));
          columns[p.name].push(values);
        } else {
          columns[p.name].push(read(p.type));
        }
      }
    }
    result[element.name] = { count: element.count, columns };
  }
  return result;
}

// An OFF file's vertices and triangles (the fixtures' plain OFF: no comments, triangles only).
export function readOff(file) {
  const words = fs.readFileSync(file, 'latin1').split(/\s+/).filter((w) => w.length > 0);
  let at = words[0] === 'OFF' ? 1 : 0;
  const vertexCount = Number(words[at]);
  const faceCount = Number(words[at + 1]);
  at += 3;
  const positions = [];
  for (let v = 0; v < vertexCount; v += 1, at += 3) positions.push([Number(words[at]), Number(words[at + 1]), Number(words[at + 2])]);
  const faces = [];
  for (let f = 0; f < faceCount; f += 1) {
    const n = Number(words[at]);
    faces.push(words.slice(at + 1, at + 1 + n).map(Number));
    at += 1 + n;
  }
  return { positions, faces };
}

// The same mesh as ASCII PLY with a colour per vertex that is a function of its position.
export function writeColouredPly(file, mesh) {
  const lo = [0, 1, 2].map((k) => Math.min(...mesh.positions.map((p) => p[k])));
  const hi = [0, 1, 2].map((k) => Math.max(...mesh.positions.map((p) => p[k])));
  const vertices = mesh.positions.map((p) => {
    const colour = p.map((c, k) => Math.round((255 * (c - lo[k])) / (hi[k] - lo[k] || 1)));
    return `${p.join(' ')} ${colour.join(' ')}`;
  });
  const header = ['ply', 'format ascii 1.0', `element vertex ${vertices.length}`, 'property float x', 'property float y',
    'property float z', 'property uchar red', 'property uchar green', 'property uchar blue',
    `element face ${mesh.faces.length}`, 'property list uchar int vertex_indices', 'end_header'];
  const faces = mesh.faces.map((f) => `${f.length} ${f.join(' ')}`);
  fs.writeFileSync(file, `${header.join('\n')}\n${vertices.join('\n')}\n${faces.join('\n')}\n`);
}
