// PLY and OFF for the viewer. PLY: binary little-endian and ASCII, positions and the colours gaussmesh writes —
// per vertex, or per face (segment and patch colours, which three.js's PLYLoader does not read).
// Polygons are split into fans. A mesh with face colours becomes one vertex per face corner, so
// each face can carry its own colour; the counts returned are the file's. Vertices with a
// nonzero `sample` property come back as points.
import * as THREE from 'three';

const kTypes = {
  char: ['getInt8', 1], int8: ['getInt8', 1], uchar: ['getUint8', 1], uint8: ['getUint8', 1],
  short: ['getInt16', 2], int16: ['getInt16', 2], ushort: ['getUint16', 2], uint16: ['getUint16', 2],
  int: ['getInt32', 4], int32: ['getInt32', 4], uint: ['getUint32', 4], uint32: ['getUint32', 4],
  float: ['getFloat32', 4], float32: ['getFloat32', 4], double: ['getFloat64', 8], float64: ['getFloat64', 8],
};

function parseHeader(bytes) {
  const text = new TextDecoder('latin1').decode(bytes.subarray(0, Math.min(bytes.length, 65536)));
  const end = text.indexOf('end_header');
  if (!text.startsWith('ply') || end < 0) throw new Error('not a PLY file');
  const lines = text.slice(0, end).split(/\r?\n/);
  const header = { format: '', elements: [], body: end + text.slice(end).indexOf('\n') + 1 };
  for (const line of lines) {
    const words = line.trim().split(/\s+/);
    if (words[0] === 'format') header.format = words[1];
    else if (words[0] === 'element') header.elements.push({ name: words[1], count: Number(words[2]), properties: [] });
    else if (words[0] === 'property') {
      const element = header.elements.at(-1);
      if (words[1] === 'list') element.properties.push({ name: words[4], list: true, countType: words[2], type: words[3] });
      else element.properties.push({ name: words[2], type: words[1] });
    }
  }
  if (header.format !== 'binary_little_endian' && header.format !== 'ascii') {
    throw new Error(`PLY format ${header.format} is not read here (binary_little_endian and ascii are)`);
  }
  return header;
}

// Reads every element as { name: [values per item] }, lists as arrays.
function readElements(bytes, header) {
  const result = {};
  if (header.format === 'ascii') {
    const words = new TextDecoder('latin1').decode(bytes.subarray(header.body)).split(/\s+/).filter((w) => w.length > 0);
    let at = 0;
    for (const element of header.elements) {
      const columns = Object.fromEntries(element.properties.map((p) => [p.name, []]));
      for (let i = 0; i < element.count; i += 1) {
        for (const p of element.properties) {
          if (p.list) {
            const n = Number(words[at++]);
            columns[p.name].push(words.slice(at, at + n).map(Number));
            at += n;
          } else {
            columns[p.name].push(Number(words[at++]));
          }
        }
      }
      result[element.name] = columns;
    }
    return result;
  }
  const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  let at = header.body;
  const read = (type) => {
    const [getter, size] = kTypes[type] ?? [];
    if (!getter) throw new Error(`PLY property type ${type}`);
    const value = view[getter](at, true);
    at += size;
    return value;
  };
  for (const element of header.elements) {
    const columns = Object.fromEntries(element.properties.map((p) => [p.name, []]));
    for (let i = 0; i < element.count; i += 1) {
      for (const p of element.properties) {
        if (p.list) {
          const n = read(p.countType);
          const list = new Array(n);
          for (let k = 0; k < n; k += 1) list[k] = read(p.type);
          columns[p.name].push(list);
        } else {
          columns[p.name].push(read(p.type));
        }
      }
    }
    result[element.name] = columns;
  }
  return result;
}

// A channel as three.js's working colour space holds it: PLY's colours are sRGB.
const channel = (value, type) => {
  const c = type === 'float' || type === 'float32' || type === 'double' ? value : value / 255;
  return c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4;
};

export function parsePly(buffer) {
  const bytes = new Uint8Array(buffer);
  const header = parseHeader(bytes);
  const elements = readElements(bytes, header);
  const vertex = elements.vertex ?? { x: [] };
  const face = elements.face ?? {};
  const corners = face.vertex_indices ?? face.vertex_index ?? [];
  const vertexCount = vertex.x.length;
  const typeOf = (name, property) => header.elements.find((e) => e.name === name)?.properties.find((p) => p.name === property)?.type;

  const triangles = [];
  const triangleFace = [];
  corners.forEach((polygon, f) => {
    for (let k = 1; k + 1 < polygon.length; k += 1) {
      triangles.push(polygon[0], polygon[k], polygon[k + 1]);
      triangleFace.push(f);
    }
  });
  for (const v of triangles) {
    if (!(v >= 0 && v < vertexCount)) throw new Error(`PLY face refers to vertex ${v} of ${vertexCount}`);
  }

  const geometry = new THREE.BufferGeometry();
  const faceColours = face.red !== undefined && face.green !== undefined && face.blue !== undefined;
  const vertexColours = vertex.red !== undefined && vertex.green !== undefined && vertex.blue !== undefined;
  if (faceColours) {
    const positions = new Float32Array(triangles.length * 3);
    const colours = new Float32Array(triangles.length * 3);
    const type = typeOf('face', 'red');
    triangles.forEach((v, c) => {
      positions.set([vertex.x[v], vertex.y[v], vertex.z[v]], 3 * c);
      const f = triangleFace[Math.floor(c / 3)];
      colours.set([channel(face.red[f], type), channel(face.green[f], type), channel(face.blue[f], type)], 3 * c);
    });
    geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
    geometry.setAttribute('color', new THREE.BufferAttribute(colours, 3));
  } else {
    const positions = new Float32Array(vertexCount * 3);
    for (let v = 0; v < vertexCount; v += 1) positions.set([vertex.x[v], vertex.y[v], vertex.z[v]], 3 * v);
    geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
    if (vertexColours) {
      const type = typeOf('vertex', 'red');
      const colours = new Float32Array(vertexCount * 3);
      for (let v = 0; v < vertexCount; v += 1) {
        colours.set([channel(vertex.red[v], type), channel(vertex.green[v], type), channel(vertex.blue[v], type)], 3 * v);
      }
      geometry.setAttribute('color', new THREE.BufferAttribute(colours, 3));
    }
    geometry.setIndex(vertexCount > 65535 ? new THREE.Uint32BufferAttribute(triangles, 1) : new THREE.Uint16BufferAttribute(triangles, 1));
  }
  // Vertices flagged by a `sample` property (gaussmesh sample --patches): the samples.
  const samples = [];
  if (vertex.sample !== undefined) {
    for (let v = 0; v < vertexCount; v += 1) if (vertex.sample[v]) samples.push(vertex.x[v], vertex.y[v], vertex.z[v]);
  }
  return { geometry, vertices: vertexCount, faces: triangles.length / 3, colours: faceColours ? 'face' : vertexColours ? 'vertex' : '',
    samples: new Float32Array(samples) };
}

// OFF (ASCII, as the fixtures are): positions and polygons, split into fans; colours ignored.
export function parseOff(buffer) {
  const text = new TextDecoder('latin1').decode(new Uint8Array(buffer));
  const words = text.replace(/#[^\n]*/g, ' ').split(/\s+/).filter((w) => w.length > 0);
  const header = words[0];
  if (!/^[A-Z]*OFF$/.test(header)) throw new Error('not an OFF file');
  let at = 1;
  const vertexCount = Number(words[at]);
  const faceCount = Number(words[at + 1]);
  at += 3;
  const perVertex = 3 + (header.includes('C') ? 3 : 0) + (header.includes('N') ? 3 : 0) + (header.includes('ST') ? 2 : 0);
  const positions = new Float32Array(vertexCount * 3);
  for (let v = 0; v < vertexCount; v += 1, at += perVertex) {
    positions.set([Number(words[at]), Number(words[at + 1]), Number(words[at + 2])], 3 * v);
  }
  const triangles = [];
  for (let f = 0; f < faceCount; f += 1) {
    const n = Number(words[at]);
    const polygon = words.slice(at + 1, at + 1 + n).map(Number);
    for (let k = 1; k + 1 < n; k += 1) triangles.push(polygon[0], polygon[k], polygon[k + 1]);
    at += 1 + n;
    while (at < words.length && !/^\d+$/.test(words[at])) at += 1;  // a face's colour
  }
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
  geometry.setIndex(vertexCount > 65535 ? new THREE.Uint32BufferAttribute(triangles, 1) : new THREE.Uint16BufferAttribute(triangles, 1));
  return { geometry, vertices: vertexCount, faces: triangles.length / 3, colours: '', samples: new Float32Array(0) };
}
