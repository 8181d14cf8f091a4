// gaussmesh's viewer: opens a .glb/.gltf, .drc, .ply, .obj or .off — the one `gaussmesh view` names
// (served: ?model=URL; self-contained: embedded in the page), or one dropped on the page — and
// shows it with its face, vertex and byte counts, and toggles for wireframe, flat shading and
// the per-face or per-vertex colours a mesh carries (segments, patches, scan colours).
// window.gaussmeshViewer holds the same figures for tests (tests/web/viewer_browser.mjs).
// The page's query sets how it starts, for figures (scripts/render-figures): panel=0 hides the
// panel, up=z for a z-up model, view=AZIMUTH,ELEVATION in degrees, zoom=Z (1: the bounding
// sphere fills the height), wireframe=0|1, flat=0|1, colours=0|1, samples=0|1, point=PIXELS.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { DRACOLoader } from 'three/addons/loaders/DRACOLoader.js';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OBJLoader } from 'three/addons/loaders/OBJLoader.js';
import { parseOff, parsePly } from './ply.js';

const state = { status: 'empty', name: '', format: '', faces: 0, vertices: 0, bytes: 0, colours: '', samples: 0, error: '' };
window.gaussmeshViewer = state;

const query = new URLSearchParams(window.location.search);
const flag = (name, fallback) => (query.has(name) ? query.get(name) !== '0' : fallback);
if (!flag('panel', true)) document.getElementById('panel').style.display = 'none';
for (const id of ['wireframe', 'flat']) document.getElementById(id).checked = flag(id, true);
const [azimuth, elevation] = (query.get('view') ?? '30,20').split(',').map(Number);
const zoom = Number(query.get('zoom') ?? 1);

const canvas = document.getElementById('view');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0xf4f4f2);
const camera = new THREE.PerspectiveCamera(35, 1, 0.01, 1000);
if (query.get('up') === 'z') camera.up.set(0, 0, 1);
scene.add(camera);
scene.add(new THREE.HemisphereLight(0xffffff, 0x505060, 1.6));
const light = new THREE.DirectionalLight(0xffffff, 1.8);
light.position.set(0.5, 1, 1.5);
camera.add(light);
const controls = new OrbitControls(camera, canvas);
controls.addEventListener('change', render);

const material = new THREE.MeshStandardMaterial({ color: 0xc8c4bc, roughness: 0.75, metalness: 0, side: THREE.DoubleSide,
  polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1 });
const edges = new THREE.LineBasicMaterial({ color: 0x202020, transparent: true, opacity: 0.55 });
const sampleMaterial = new THREE.PointsMaterial({ color: 0xd01010, size: Number(query.get('point') ?? 5), sizeAttenuation: false });
let shown = null;  // { object, wire, points }

// The Draco decoder's files: beside the page when served, embedded in a self-contained page.
const manager = new THREE.LoadingManager();
const embedded = window.gaussmeshEmbedded;
const bytesOf = (base64) => Uint8Array.from(atob(base64), (c) => c.charCodeAt(0));
if (embedded) {
  const urls = {};
  for (const [name, base64] of Object.entries(embedded.draco)) urls[name] = URL.createObjectURL(new Blob([bytesOf(base64)]));
  manager.setURLModifier((url) => urls[url.split('/').pop()] ?? url);
}
const draco = new DRACOLoader(manager);
draco.setDecoderPath('draco/');

function render() {
  renderer.render(scene, camera);
}

function resize() {
  const width = canvas.clientWidth;
  const height = canvas.clientHeight;
  renderer.setSize(width, height, false);
  camera.aspect = width / Math.max(height, 1);
  camera.updateProjectionMatrix();
  render();
}
window.addEventListener('resize', resize);

function show(object, figures) {
  if (shown) for (const part of [shown.object, shown.wire, shown.points]) scene.remove(part);
  let colours = figures.colours ?? '';
  const meshes = [];
  object.traverse((child) => {
    if (!child.isMesh) return;
    if (child.geometry.getAttribute('color')) colours = colours || 'vertex';
    if (!child.geometry.getAttribute('normal')) child.geometry.computeVertexNormals();
    child.material = material;
    meshes.push(child);
  });
  const wire = new THREE.Group();
  for (const mesh of meshes) {
    const lines = new THREE.LineSegments(new THREE.WireframeGeometry(mesh.geometry), edges);
    lines.matrixAutoUpdate = false;
    lines.matrix = mesh.matrixWorld;
    wire.add(lines);
  }
  const samples = figures.samples ?? new Float32Array(0);
  const points = new THREE.Points(new THREE.BufferGeometry().setAttribute('position', new THREE.BufferAttribute(samples, 3)), sampleMaterial);
  scene.add(object);
  scene.add(wire);
  scene.add(points);
  object.updateMatrixWorld(true);
  shown = { object, wire, points };

  // Framing: look along the view direction, then fit what the mesh's vertices span across and
  // up the screen, centred, with a margin (zoom > 1 comes closer).
  const a = THREE.MathUtils.degToRad(azimuth);
  const e = THREE.MathUtils.degToRad(elevation);
  const direction = camera.up.z === 1
    ? new THREE.Vector3(Math.sin(a) * Math.cos(e), -Math.cos(a) * Math.cos(e), Math.sin(e))
    : new THREE.Vector3(Math.sin(a) * Math.cos(e), Math.sin(e), Math.cos(a) * Math.cos(e));
  const right = new THREE.Vector3().crossVectors(camera.up, direction).normalize();
  const up = new THREE.Vector3().crossVectors(direction, right).normalize();
  const lo = [Infinity, Infinity, Infinity];
  const hi = [-Infinity, -Infinity, -Infinity];
  const p = new THREE.Vector3();
  object.traverse((child) => {
    if (!child.isMesh) return;
    const positions = child.geometry.getAttribute('position');
    for (let i = 0; i < positions.count; i += 1) {
      p.fromBufferAttribute(positions, i).applyMatrix4(child.matrixWorld);
      [right, up, direction].forEach((axis, k) => {
        const t = p.dot(axis);
        lo[k] = Math.min(lo[k], t);
        hi[k] = Math.max(hi[k], t);
      });
    }
  });
  const centre = right.clone().multiplyScalar((lo[0] + hi[0]) / 2)
    .add(up.clone().multiplyScalar((lo[1] + hi[1]) / 2))
    .add(direction.clone().multiplyScalar((lo[2] + hi[2]) / 2));
  const tangent = Math.tan(THREE.MathUtils.degToRad(camera.fov / 2));
  const halfWidth = Math.max((hi[0] - lo[0]) / 2, 1e-9);
  const halfHeight = Math.max((hi[1] - lo[1]) / 2, 1e-9);
  const depth = (hi[2] - lo[2]) / 2;
  const distance = (Math.max(halfHeight / tangent, halfWidth / (tangent * camera.aspect)) * 1.15) / zoom + depth;
  camera.position.copy(centre).add(direction.clone().multiplyScalar(distance));
  camera.near = Math.max(distance - depth, 1e-6) / 100;
  camera.far = (distance + depth) * 100;
  camera.updateProjectionMatrix();
  controls.target.copy(centre);
  controls.update();

  Object.assign(state, figures, { colours, samples: samples.length / 3, status: 'ready', error: '' });
  document.getElementById('colours').disabled = colours === '';
  document.getElementById('colours').checked = colours !== '' && flag('colours', true);
  points.visible = flag('samples', true);
  applyToggles();
  for (const key of ['name', 'format', 'faces', 'vertices', 'bytes']) {
    const value = state[key];
    document.getElementById(key).textContent = typeof value === 'number' ? value.toLocaleString('en') : value;
  }
  document.getElementById('colours-kind').textContent = colours ? `(${colours})` : '(none)';
  document.getElementById('message').textContent = '';
}

function applyToggles() {
  material.flatShading = document.getElementById('flat').checked;
  material.vertexColors = document.getElementById('colours').checked && state.colours !== '';
  material.color.set(material.vertexColors ? 0xffffff : 0xc8c4bc);
  material.needsUpdate = true;
  if (shown) shown.wire.visible = document.getElementById('wireframe').checked;
  render();
}
for (const id of ['wireframe', 'flat', 'colours']) document.getElementById(id).addEventListener('change', applyToggles);

function fail(name, error) {
  Object.assign(state, { status: 'error', name, error: String(error && error.message ? error.message : error) });
  document.getElementById('message').textContent = `${name}: ${state.error}`;
}

function counts(object) {
  let faces = 0;
  let vertices = 0;
  object.traverse((child) => {
    if (!child.isMesh) return;
    const g = child.geometry;
    faces += (g.index ? g.index.count : g.getAttribute('position').count) / 3;
    vertices += g.getAttribute('position').count;
  });
  return { faces, vertices };
}

// What the bytes are, by their first bytes: glTF binary, Draco, PLY, OFF, glTF JSON; else OBJ.
function detect(bytes) {
  const head = new TextDecoder('latin1').decode(bytes.subarray(0, 5));
  if (head.startsWith('glTF')) return 'glb';
  if (head === 'DRACO') return 'drc';
  if (head.startsWith('ply')) return 'ply';
  if (/^[A-Z]*OFF\s/.test(new TextDecoder('latin1').decode(bytes.subarray(0, 8)))) return 'off';
  if (head.trimStart().startsWith('{')) return 'gltf';
  return 'obj';
}

async function open(name, buffer) {
  state.status = 'loading';
  document.getElementById('message').textContent = `loading ${name}`;
  const bytes = new Uint8Array(buffer);
  const size = bytes.length;  // the Draco decoder's worker takes the buffer itself
  const format = detect(bytes);
  try {
    if (format === 'glb' || format === 'gltf') {
      const loader = new GLTFLoader(manager);
      loader.setDRACOLoader(draco);
      const gltf = await loader.parseAsync(buffer, '');
      show(gltf.scene, { name, format, bytes: size, ...counts(gltf.scene) });
    } else if (format === 'drc') {
      const geometry = await new Promise((resolve, reject) => {
        draco.parse(buffer, resolve, reject);
      });
      const mesh = new THREE.Mesh(geometry, material);
      show(mesh, { name, format, bytes: size, ...counts(mesh) });
    } else if (format === 'ply' || format === 'off') {
      const parsed = format === 'ply' ? parsePly(buffer) : parseOff(buffer);
      show(new THREE.Mesh(parsed.geometry, material),
        { name, format, bytes: size, faces: parsed.faces, vertices: parsed.vertices, colours: parsed.colours, samples: parsed.samples });
    } else {
      const text = new TextDecoder().decode(bytes);
      const object = new OBJLoader(manager).parse(text);
      // OBJLoader gives every face corner its own vertex: the file's vertices are its v lines.
      const vertices = (text.match(/^v\s/gm) ?? []).length;
      show(object, { name, format, bytes: size, faces: counts(object).faces, vertices });
    }
  } catch (error) {
    fail(name, error);
  }
}

window.addEventListener('dragover', (event) => event.preventDefault());
window.addEventListener('drop', async (event) => {
  event.preventDefault();
  const file = event.dataTransfer.files[0];
  if (file) open(file.name, await file.arrayBuffer());
});
document.getElementById('file').addEventListener('change', async (event) => {
  const file = event.target.files[0];
  if (file) open(file.name, await file.arrayBuffer());
});

resize();
const wanted = query.get('model');
if (embedded) {
  open(embedded.name, bytesOf(embedded.model).buffer);
} else if (wanted) {
  fetch(wanted)
    .then((response) => {
      if (!response.ok) throw new Error(`HTTP ${response.status}`);
      return response.arrayBuffer();
    })
    .then((buffer) => open(decodeURIComponent(wanted.split('/').pop()), buffer))
    .catch((error) => fail(wanted, error));
} else {
  document.getElementById('message').textContent = 'drop a .glb, .drc, .ply, .obj or .off file here';
}
