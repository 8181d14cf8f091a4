// gaussmesh's viewer: opens a .glb/.gltf, .drc, .ply or .obj — the one `gaussmesh view` names
// (served: ?model=URL; self-contained: embedded in the page), or one dropped on the page — and
// shows it with its face, vertex and byte counts, and toggles for wireframe, flat shading and
// the per-face or per-vertex colours a mesh carries (segments, patches, scan colours).
// window.gaussmeshViewer holds the same figures for tests (tests/web/viewer_browser.mjs).
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { DRACOLoader } from 'three/addons/loaders/DRACOLoader.js';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OBJLoader } from 'three/addons/loaders/OBJLoader.js';
import { parsePly } from './ply.js';

const state = { status: 'empty', name: '', format: '', faces: 0, vertices: 0, bytes: 0, colours: '', error: '' };
window.gaussmeshViewer = state;

const canvas = document.getElementById('view');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0xf4f4f2);
const camera = new THREE.PerspectiveCamera(35, 1, 0.01, 1000);
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
let shown = null;  // { object, wire }

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
  if (shown) {
    scene.remove(shown.object);
    if (shown.wire) scene.remove(shown.wire);
  }
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
  scene.add(object);
  scene.add(wire);
  object.updateMatrixWorld(true);
  shown = { object, wire };

  const box = new THREE.Box3().setFromObject(object);
  const sphere = box.getBoundingSphere(new THREE.Sphere());
  const radius = sphere.radius || 1;
  const distance = radius / Math.sin(THREE.MathUtils.degToRad(camera.fov / 2)) * 1.05;
  camera.position.copy(sphere.center).add(new THREE.Vector3(0.55, 0.35, 1).normalize().multiplyScalar(distance));
  camera.near = distance / 100;
  camera.far = distance * 100;
  camera.updateProjectionMatrix();
  controls.target.copy(sphere.center);
  controls.update();

  Object.assign(state, figures, { colours, status: 'ready', error: '' });
  document.getElementById('colours').disabled = colours === '';
  document.getElementById('colours').checked = colours !== '';
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

// What the bytes are, by their first bytes: glTF binary, Draco, PLY, glTF JSON; else OBJ.
function detect(bytes) {
  const head = new TextDecoder('latin1').decode(bytes.subarray(0, 5));
  if (head.startsWith('glTF')) return 'glb';
  if (head === 'DRACO') return 'drc';
  if (head.startsWith('ply')) return 'ply';
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
    } else if (format === 'ply') {
      const ply = parsePly(buffer);
      show(new THREE.Mesh(ply.geometry, material), { name, format, bytes: size, faces: ply.faces, vertices: ply.vertices, colours: ply.colours });
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
const wanted = new URLSearchParams(window.location.search).get('model');
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
  document.getElementById('message').textContent = 'drop a .glb, .drc, .ply or .obj file here';
}
