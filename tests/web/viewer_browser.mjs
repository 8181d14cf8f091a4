// The viewer in a real browser (Debian's Chromium, headless, driven by playwright-core): every
// fixture simplified to .glb and to .drc, a segmentation's face-coloured .ply, an .obj and a
// coloured .gltf, each opened in the self-contained page `gaussmesh view FILE --html` writes;
// the page must report the
// face and vertex counts gaussmesh reported and the file's bytes, and draw the mesh: the canvas
// may not be blank. One model is also opened through the server `gaussmesh view FILE` starts,
// which must stop with exit 0 on SIGINT. Screenshots go to --screenshots DIR.
import { execFileSync, spawn } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { check, finish, kSkipped, options, requireModules, scratch, simplify, writeAttributedTorus } from './support.mjs';

const { gaussmesh, modules, root } = options();
const args = process.argv.slice(2);
const screenshots = args.includes('--screenshots') ? args[args.indexOf('--screenshots') + 1] : scratch();
const chromiumPath = args.includes('--chromium') ? args[args.indexOf('--chromium') + 1] : '/usr/bin/chromium';
const { 'playwright-core': playwright } = requireModules(modules, ['playwright-core']);
if (!fs.existsSync(chromiumPath)) {
  console.log(`SKIPPED: no Chromium at ${chromiumPath} (scripts/bootstrap test installs Debian's chromium)`);
  process.exit(kSkipped);
}
const dir = scratch();
const viewerProbe = spawnSyncStatus(gaussmesh, ['view', path.join(root, 'fixtures/real/cow.off'), '--html', path.join(dir, 'probe.html'), '-q']);
if (viewerProbe.status === 1 && viewerProbe.stderr.includes('viewer is not built')) {
  console.log(`SKIPPED: ${viewerProbe.stderr.trim()}`);
  process.exit(kSkipped);
}
fs.mkdirSync(screenshots, { recursive: true });

function spawnSyncStatus(command, argv) {
  try {
    execFileSync(command, argv, { stdio: ['ignore', 'ignore', 'pipe'] });
    return { status: 0, stderr: '' };
  } catch (error) {
    return { status: error.status, stderr: String(error.stderr) };
  }
}

// SwiftShader: WebGL on the CPU, as on a machine without a GPU.
const browser = await playwright.chromium.launch({
  executablePath: chromiumPath,
  args: ['--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist'],
});
const page = await browser.newPage({ viewport: { width: 640, height: 480 } });
const pageErrors = [];
page.on('pageerror', (error) => pageErrors.push(error.message));

// Opens url, waits for the viewer to finish, and returns what it reports and how much of the
// canvas differs from the background.
async function look(url, shot) {
  pageErrors.length = 0;
  await page.goto(url);
  await page.waitForFunction(() => ['ready', 'error'].includes(window.gaussmeshViewer?.status), null, { timeout: 60000 });
  const state = await page.evaluate(() => ({ ...window.gaussmeshViewer }));
  const drawn = await page.evaluate(() => {
    const canvas = document.getElementById('view');
    const copy = document.createElement('canvas');
    copy.width = canvas.width;
    copy.height = canvas.height;
    const context = copy.getContext('2d');
    context.drawImage(canvas, 0, 0);
    const pixels = context.getImageData(0, 0, copy.width, copy.height).data;
    const [r, g, b] = [pixels[0], pixels[1], pixels[2]];  // a corner: the background
    let differ = 0;
    for (let i = 0; i < pixels.length; i += 4) {
      if (Math.abs(pixels[i] - r) + Math.abs(pixels[i + 1] - g) + Math.abs(pixels[i + 2] - b) > 24) differ += 1;
    }
    return differ / (pixels.length / 4);
  });
  await page.screenshot({ path: path.join(screenshots, shot) });
  return { state, drawn };
}

function expect(label, seen, report, file) {
  const { state, drawn } = seen;
  check(state.status === 'ready', `${label}: the viewer says ${state.status} ${state.error}`);
  check(pageErrors.length === 0, `${label}: page errors ${pageErrors.join('; ')}`);
  check(state.faces === report.faces, `${label}: the viewer shows ${state.faces} faces, gaussmesh wrote ${report.faces}`);
  check(state.vertices === report.vertices, `${label}: the viewer shows ${state.vertices} vertices, gaussmesh wrote ${report.vertices}`);
  check(state.bytes === fs.statSync(file).size, `${label}: the viewer shows ${state.bytes} bytes of ${fs.statSync(file).size}`);
  check(drawn > 0.02, `${label}: the canvas is blank (${(100 * drawn).toFixed(2)} % of it drawn)`);
  return drawn;
}

let pages = 0;
const fixtures = fs.readdirSync(path.join(root, 'fixtures/real')).filter((f) => /\.(off|ply)$/.test(f)).sort();
for (const fixture of fixtures) {
  const stem = fixture.replace(/\.[a-z]+$/, '');
  for (const extension of ['glb', 'drc']) {
    const output = path.join(dir, `${stem}.${extension}`);
    const report = simplify(gaussmesh, path.join(root, 'fixtures/real', fixture), output);
    const html = path.join(dir, `${stem}-${extension}.html`);
    execFileSync(gaussmesh, ['view', output, '--html', html, '-q']);
    expect(`${fixture} .${extension}`, await look(`file://${html}`, `${stem}-${extension}.png`),
      { faces: report.output_faces, vertices: report.output_vertices }, output);
    pages += 1;
  }
}

// A segmentation (colours per face) and an OBJ.
const segments = path.join(dir, 'knot1-segments.ply');
const segmentReport = JSON.parse(execFileSync(gaussmesh, ['segment', path.join(root, 'fixtures/real/knot1.off'), '-o', segments, '--report', '-', '-q']));
const segmentsHtml = path.join(dir, 'segments.html');
execFileSync(gaussmesh, ['view', segments, '--html', segmentsHtml, '-q']);
const segmentsSeen = await look(`file://${segmentsHtml}`, 'knot1-segments.png');
expect('segmentation .ply', segmentsSeen, { faces: segmentReport.input_faces ?? segmentReport.faces, vertices: segmentReport.input_vertices ?? segmentReport.vertices }, segments);
check(segmentsSeen.state.colours === 'face', `segmentation .ply: colours ${segmentsSeen.state.colours}, expected per face`);
const obj = path.join(dir, 'fandisk.obj');
const objReport = simplify(gaussmesh, path.join(root, 'fixtures/real/fandisk.off'), obj, ['--ratio', '0.1']);
const objHtml = path.join(dir, 'fandisk-obj.html');
execFileSync(gaussmesh, ['view', obj, '--html', objHtml, '-q']);
expect('fandisk .obj', await look(`file://${objHtml}`, 'fandisk-obj.png'), { faces: objReport.output_faces, vertices: objReport.output_vertices }, obj);
// A .gltf (JSON, the buffer a data URI) of a mesh with colours, normals and texture coordinates:
// the page must find the vertex colours.
const torus = path.join(dir, 'torus.ply');
writeAttributedTorus(torus, 120, 60);
const gltf = path.join(dir, 'torus.gltf');
const gltfReport = simplify(gaussmesh, torus, gltf, ['--ratio', '0.05']);
const gltfHtml = path.join(dir, 'torus-gltf.html');
execFileSync(gaussmesh, ['view', gltf, '--html', gltfHtml, '-q']);
const gltfSeen = await look(`file://${gltfHtml}`, 'torus-gltf.png');
expect('attributed torus .gltf', gltfSeen, { faces: gltfReport.output_faces, vertices: gltfReport.output_vertices }, gltf);
check(gltfSeen.state.colours === 'vertex', `attributed torus .gltf: colours ${gltfSeen.state.colours}, expected per vertex`);
pages += 3;

// Served: the URL comes on the first line of standard output; SIGINT stops the server.
const served = path.join(dir, 'cow.glb');
const server = spawn(gaussmesh, ['view', served, '-q'], { stdio: ['ignore', 'pipe', 'inherit'] });
const url = await new Promise((resolve, reject) => {
  let text = '';
  server.stdout.on('data', (data) => {
    text += data;
    if (text.includes('\n')) resolve(text.split('\n')[0]);
  });
  server.on('exit', (code) => reject(new Error(`gaussmesh view exited ${code} before printing its URL`)));
});
check(/^http:\/\/127\.0\.0\.1:\d+\/\?model=model\/cow\.glb$/.test(url), `served: URL ${url}`);
const cowReport = JSON.parse(fs.readFileSync(`${served}.json`, 'utf8'));
expect('served cow.glb', await look(url, 'cow-served.png'), { faces: cowReport.output_faces, vertices: cowReport.output_vertices }, served);
const exit = new Promise((resolve) => server.on('exit', (code, signal) => resolve({ code, signal })));
server.kill('SIGINT');
const ended = await exit;
check(ended.code === 0, `served: gaussmesh view ended with ${JSON.stringify(ended)} on SIGINT`);
pages += 1;

await browser.close();
finish(`${pages} pages in Chromium, screenshots in ${screenshots}`);
