// A coloured mesh simplified to 1 % as .drc (issue: attributes through to Draco): npm's draco3d,
// what a browser decodes with, and Google's draco_decoder give back the same points with the same
// positions, colours, normals and texture coordinates, and the face count gaussmesh reported.
// Inputs: a generated torus with colour a function of position, normals and texture
// coordinates, and the cow fixture given colours the same way.
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { check, decodeDraco, finish, options, readDracoDecoderPly, readOff, requireModules, scratch, simplify,
  writeAttributedTorus, writeColouredPly } from './support.mjs';

const { gaussmesh, modules, root } = options();
const { draco3d } = requireModules(modules, ['draco3d']);
const decoderModule = await draco3d.createDecoderModule({});
const dir = scratch();

// draco_decoder's PLY names each vertex attribute's columns so; texture coordinates it writes
// per face corner.
const kColumns = { POSITION: ['x', 'y', 'z'], NORMAL: ['nx', 'ny', 'nz'], COLOR: ['red', 'green', 'blue', 'alpha'] };

function compare(name, input, expected) {
  const drc = path.join(dir, `${name}.drc`);
  const report = simplify(gaussmesh, input, drc, ['--ratio', '0.01']);
  const decoded = decodeDraco(decoderModule, fs.readFileSync(drc));
  if (!check(decoded.ok, `${name}: draco3d decodes it (${decoded.error})`)) return;
  check(decoded.faces.length === report.output_faces, `${name}: ${decoded.faces.length} faces, the report says ${report.output_faces}`);
  const ply = path.join(dir, `${name}-decoded.ply`);
  execFileSync('draco_decoder', ['-i', drc, '-o', ply], { stdio: 'ignore' });
  const { vertex: reference, face: referenceFaces } = readDracoDecoderPly(ply);
  check(reference.count === decoded.points, `${name}: draco_decoder gives ${reference.count} points, draco3d ${decoded.points}`);
  check(JSON.stringify(referenceFaces.columns.vertex_indices) === JSON.stringify(decoded.faces), `${name}: the same faces`);
  const found = [];
  for (const attribute of decoded.byUniqueId.values()) {
    const type = Object.keys(decoderModule).find((k) => ['POSITION', 'NORMAL', 'COLOR', 'TEX_COORD'].includes(k) && decoderModule[k] === attribute.type);
    found.push(type);
    if (type === 'TEX_COORD') {
      let differ = 0;
      decoded.faces.forEach((face, f) => face.forEach((point, c) => [0, 1].forEach((k) => {
        if (Math.fround(attribute.values[2 * point + k]) !== Math.fround(referenceFaces.columns.texcoord[f][2 * c + k])) differ += 1;
      })));
      check(differ === 0, `${name}: TEX_COORD: ${differ} corner values differ between draco3d and draco_decoder`);
      continue;
    }
    const columns = kColumns[type].slice(0, attribute.components);
    let differ = 0;
    for (let p = 0; p < decoded.points; p += 1) {
      columns.forEach((column, k) => {
        const mine = attribute.values[p * attribute.components + k];
        const theirs = reference.columns[column]?.[p];
        if (type === 'COLOR' ? mine !== theirs : Math.fround(mine) !== Math.fround(theirs)) differ += 1;
      });
    }
    check(differ === 0, `${name}: ${type}: ${differ} values differ between draco3d and draco_decoder`);
  }
  check(JSON.stringify(found.sort()) === JSON.stringify([...expected].sort()), `${name}: attributes ${found} (expected ${expected})`);
  return decoded.points;
}

const torus = path.join(dir, 'torus.ply');
writeAttributedTorus(torus, 200, 100);
const torusPoints = compare('torus', torus, ['POSITION', 'NORMAL', 'COLOR', 'TEX_COORD']);
const cow = path.join(dir, 'cow.ply');
writeColouredPly(cow, readOff(path.join(root, 'fixtures/real/cow.off')));
const cowPoints = compare('cow', cow, ['POSITION', 'COLOR']);
finish(`draco3d and draco_decoder agree on ${torusPoints} + ${cowPoints} points of two coloured 1 % outputs`);
