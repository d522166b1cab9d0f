// Penumbra's web viewer (docs/web-viewer.md): a glTF written by `penumbra bake`, shaded by its
// baked lightmap (the PENUMBRA_lightmap material extension) with three.js.
//
// Query parameters: `gltf=NAME.gltf` (default: the `gltf` entry of bake.json beside the page),
// `exposure=X` (linear factor; default: a key of 0.18 over the lightmaps' log-average radiance),
// `ui=0` (no panel, for screenshots).
//
// For tests: `window.penumbraReady` turns true after the first frame; `penumbraSetExposure(x)` and
// `penumbraUseFileCamera()` return promises resolved once the new frame is drawn;
// `window.penumbraInfo` describes what was loaded; `window.penumbraError` holds a load error.

import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const EXTENSION = 'PENUMBRA_lightmap';
const EXPOSURE_MIN_STOPS = -8;
const EXPOSURE_MAX_STOPS = 8;

const params = new URLSearchParams(window.location.search);
const canvas = document.getElementById('view');
const statusLine = document.getElementById('status');
const exposureSlider = document.getElementById('exposure');
const exposureValue = document.getElementById('exposure-value');
if (params.get('ui') === '0') document.body.classList.add('bare');

window.penumbraReady = false;
window.penumbraError = null;

function setStatus(text) {
  statusLine.textContent = text;
  statusLine.classList.remove('error');
}

function showError(message, cause) {
  window.penumbraError = message;
  statusLine.textContent = message;
  statusLine.classList.add('error');
  console.error(`penumbra viewer: ${message}`, ...(cause ? [cause] : []));
}

window.addEventListener('error', (event) => showError(`script error: ${event.message}`));
window.addEventListener('unhandledrejection', (event) =>
  showError(`error: ${event.reason?.message ?? event.reason}`));

// ---------------------------------------------------------------------------------------------
// The lightmap: an RGBM PNG, linear, irradiance E = scale * (R, G, B) * A with every byte / 255.

// The PNG's bytes as they are in the file: no premultiplication by alpha (which carries M) and
// no colour conversion (the image is linear data). A 2D canvas would store premultiplied pixels
// and lose the low-M texels' precision, so the bitmap goes through a WebGL texture instead.
async function readRgbaBytes(renderer, blob) {
  const bitmap = await createImageBitmap(blob, {
    premultiplyAlpha: 'none',
    colorSpaceConversion: 'none',
    imageOrientation: 'from-image',
  });
  const gl = renderer.getContext();
  const texture = gl.createTexture();
  const framebuffer = gl.createFramebuffer();
  try {
    gl.bindTexture(gl.TEXTURE_2D, texture);
    gl.pixelStorei(gl.UNPACK_FLIP_Y_WEBGL, false);
    gl.pixelStorei(gl.UNPACK_PREMULTIPLY_ALPHA_WEBGL, false);
    gl.pixelStorei(gl.UNPACK_COLORSPACE_CONVERSION_WEBGL, gl.NONE);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, gl.RGBA, gl.UNSIGNED_BYTE, bitmap);
    gl.bindFramebuffer(gl.FRAMEBUFFER, framebuffer);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, texture, 0);
    if (gl.checkFramebufferStatus(gl.FRAMEBUFFER) !== gl.FRAMEBUFFER_COMPLETE) {
      throw new Error('cannot read the lightmap back from WebGL (framebuffer incomplete)');
    }
    const bytes = new Uint8Array(bitmap.width * bitmap.height * 4);
    gl.pixelStorei(gl.PACK_ALIGNMENT, 1);
    // Row 0 of the read-back is the texture's row 0, the image's top row (no flip on upload).
    gl.readPixels(0, 0, bitmap.width, bitmap.height, gl.RGBA, gl.UNSIGNED_BYTE, bytes);
    return { width: bitmap.width, height: bitmap.height, bytes };
  } finally {
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.deleteFramebuffer(framebuffer);
    gl.deleteTexture(texture);
    bitmap.close();
    renderer.resetState();  // three.js caches GL state; we changed bindings behind its back
  }
}

// The image a glTF texture shows, as a Blob: by URI (relative to the glTF, or a data: URI) or
// from a buffer view.
async function textureImageBlob(parser, gltfUrl, textureIndex) {
  const textureDef = parser.json.textures?.[textureIndex];
  if (!textureDef) throw new Error(`texture ${textureIndex} does not exist`);
  if (textureDef.source === undefined) throw new Error(`texture ${textureIndex} has no source image`);
  const imageDef = parser.json.images?.[textureDef.source];
  if (!imageDef) throw new Error(`image ${textureDef.source} does not exist`);
  if (imageDef.bufferView !== undefined) {
    const buffer = await parser.getDependency('bufferView', imageDef.bufferView);
    return new Blob([buffer], { type: imageDef.mimeType ?? 'image/png' });
  }
  const url = new URL(imageDef.uri, gltfUrl).href;
  const response = await fetch(url);
  if (!response.ok) throw new Error(`${imageDef.uri}: HTTP ${response.status}`);
  return response.blob();
}

// Decodes RGBM into linear irradiance, W m^-2, as a float texture (half float where the device
// cannot filter 32-bit floats linearly). Row 0 is the image's top row and flipY is false, as
// three.js's GLTFLoader keeps glTF textures: UV (0, 0) is the image's top-left corner.
function irradianceTexture(renderer, image, scale) {
  const { width, height, bytes } = image;
  const count = width * height;
  const useFloat = renderer.extensions.has('OES_texture_float_linear');
  const data = useFloat ? new Float32Array(count * 4) : new Uint16Array(count * 4);
  const k = scale / (255 * 255);
  let logSum = 0;
  let lit = 0;
  for (let i = 0; i < count; ++i) {
    const m = bytes[4 * i + 3] * k;
    const r = bytes[4 * i] * m;
    const g = bytes[4 * i + 1] * m;
    const b = bytes[4 * i + 2] * m;
    if (useFloat) {
      data[4 * i] = r;
      data[4 * i + 1] = g;
      data[4 * i + 2] = b;
      data[4 * i + 3] = 1;
    } else {
      data[4 * i] = THREE.DataUtils.toHalfFloat(Math.min(r, 65504));
      data[4 * i + 1] = THREE.DataUtils.toHalfFloat(Math.min(g, 65504));
      data[4 * i + 2] = THREE.DataUtils.toHalfFloat(Math.min(b, 65504));
      data[4 * i + 3] = THREE.DataUtils.toHalfFloat(1);
    }
    const luminance = 0.2126 * r + 0.7152 * g + 0.0722 * b;
    if (luminance > 0) {
      logSum += Math.log(luminance / Math.PI);  // the radiance of a white surface
      ++lit;
    }
  }
  const texture = new THREE.DataTexture(data, width, height, THREE.RGBAFormat,
                                        useFloat ? THREE.FloatType : THREE.HalfFloatType);
  texture.minFilter = THREE.LinearFilter;
  texture.magFilter = THREE.LinearFilter;
  texture.wrapS = THREE.ClampToEdgeWrapping;
  texture.wrapT = THREE.ClampToEdgeWrapping;
  texture.generateMipmaps = false;
  texture.flipY = false;
  texture.colorSpace = THREE.LinearSRGBColorSpace;
  texture.needsUpdate = true;
  return { texture, logSum, lit, type: useFloat ? 'float' : 'half-float' };
}

// Lightmapped materials are shown as Lambertian, as Penumbra shades them: base colour * E / pi +
// emissive. three.js adds a light map's texel to the irradiance and multiplies by
// BRDF_Lambert = base colour / pi, but its MeshStandardMaterial also takes the dielectric
// specular lobe's share (about 4%, more at grazing angles) out of the diffuse term, even with no
// light to reflect; a MeshPhysicalMaterial with specularIntensity 0 has no specular lobe at all.
// So these materials load as MeshPhysicalMaterial (this GLTFLoader plugin), and applyLightmaps()
// turns off what would add to or take from the diffuse term.
class PenumbraLightmapPlugin {
  constructor(parser) {
    this.parser = parser;
    this.name = EXTENSION;
  }

  getMaterialType(materialIndex) {
    const ext = this.parser.json.materials?.[materialIndex]?.extensions?.[EXTENSION];
    return ext ? THREE.MeshPhysicalMaterial : null;
  }
}

function makeLambertian(material) {
  if ('metalness' in material) material.metalness = 0;
  if (material.isMeshPhysicalMaterial) {
    material.specularIntensity = 0;
    material.specularIntensityMap = null;
    material.clearcoat = 0;
    material.sheen = 0;
    material.iridescence = 0;
    material.transmission = 0;
  }
  material.aoMap = null;  // the lightmap holds the occlusion already
}

// Puts every PENUMBRA_lightmap on its materials as material.lightMap = E: a MeshPhysicalMaterial
// (or, for KHR_materials_unlit, a MeshBasicMaterial, which multiplies its light map by
// colour / pi too) then shows E * base colour / pi + emissive.
async function applyLightmaps(renderer, gltf, gltfUrl) {
  const parser = gltf.parser;
  const materialDefs = parser.json.materials ?? [];
  const decoded = new Map();  // "texture/scale" -> Promise of irradianceTexture()
  const perChannel = new Map();  // "texture/scale/channel" -> THREE.Texture
  const materials = new Set();
  const problems = [];
  const jobs = [];
  gltf.scene.traverse((object) => {
    if (!object.isMesh) return;
    const list = Array.isArray(object.material) ? object.material : [object.material];
    for (const material of list) {
      const index = parser.associations.get(material)?.materials;
      const ext = materialDefs[index]?.extensions?.[EXTENSION];
      if (!ext) continue;
      const channel = ext.texCoord ?? 0;
      const where = `material ${index}${material.name ? ` (${material.name})` : ''}`;
      if (ext.encoding !== undefined && ext.encoding !== 'RGBM') {
        problems.push(`${where}: lightmap encoding "${ext.encoding}" is not RGBM`);
        continue;
      }
      if (!(Number.isInteger(channel) && channel >= 0 && channel <= 3)) {
        problems.push(`${where}: lightmap texCoord ${channel}: three.js reads TEXCOORD_0..3`);
        continue;
      }
      const attribute = channel === 0 ? 'uv' : `uv${channel}`;
      if (!object.geometry.getAttribute(attribute)) {
        problems.push(`${where}: mesh "${object.name}" has no TEXCOORD_${channel}`);
        continue;
      }
      if (!(typeof ext.scale === 'number' && ext.scale > 0)) {
        problems.push(`${where}: lightmap scale ${ext.scale} is not a positive number`);
        continue;
      }
      const source = `${ext.index}/${ext.scale}`;
      if (!decoded.has(source)) {
        decoded.set(source, textureImageBlob(parser, gltfUrl, ext.index)
          .then((blob) => readRgbaBytes(renderer, blob))
          .then((image) => irradianceTexture(renderer, image, ext.scale)));
      }
      jobs.push(decoded.get(source).then((lightmap) => {
        const key = `${source}/${channel}`;
        if (!perChannel.has(key)) {
          const texture = lightmap.texture.clone();  // shares the image: one upload
          texture.channel = channel;
          perChannel.set(key, texture);
        }
        material.lightMap = perChannel.get(key);
        material.lightMapIntensity = 1;
        makeLambertian(material);
        material.needsUpdate = true;
        materials.add(material);
      }));
    }
  });
  if (problems.length) throw new Error(problems.join('\n'));
  await Promise.all(jobs);
  const lightmaps = await Promise.all(decoded.values());
  let logSum = 0;
  let lit = 0;
  for (const l of lightmaps) {
    logSum += l.logSum;
    lit += l.lit;
  }
  return {
    materials: materials.size,
    textures: lightmaps.map((l) => ({ width: l.texture.image.width,
                                      height: l.texture.image.height, type: l.type })),
    logAverageRadiance: lit ? Math.exp(logSum / lit) : 0,
  };
}

// ---------------------------------------------------------------------------------------------
// Scene, cameras, frames.

function createRenderer() {
  try {
    const r = new THREE.WebGLRenderer({ canvas, antialias: true });
    r.setPixelRatio(window.devicePixelRatio);
    r.setSize(window.innerWidth, window.innerHeight, false);
    r.outputColorSpace = THREE.SRGBColorSpace;
    r.toneMapping = THREE.LinearToneMapping;
    r.toneMappingExposure = 1;
    return r;
  } catch (error) {
    showError(`WebGL 2 is not available: ${error.message}`, error);
    return null;
  }
}

const renderer = createRenderer();
const scene = new THREE.Scene();  // no environment map, no lights of the page's own
let camera = new THREE.PerspectiveCamera(45, 1, 0.01, 100);
let controls = null;
let fileCamera = null;  // the glTF's first camera, if any
let fileCameraHasFar = false;
let fitFar = true;  // no far plane given: keep the scene inside the frustum
const bounds = new THREE.Box3();
const boundingSphere = new THREE.Sphere(new THREE.Vector3(), 1);

let frameRequested = false;
let frameWaiters = [];
function requestFrame() {
  if (frameRequested) return;
  frameRequested = true;
  requestAnimationFrame(() => {
    frameRequested = false;
    if (fitFar) fitFarPlane();
    renderer.render(scene, camera);
    const waiters = frameWaiters;
    frameWaiters = [];
    // One more animation frame: the drawn frame has then been handed to the compositor.
    requestAnimationFrame(() => waiters.forEach((resolve) => resolve()));
  });
}
function drawFrame() {
  return new Promise((resolve) => {
    frameWaiters.push(resolve);
    requestFrame();
  });
}

// Without a far plane from the file, keep the scene inside the frustum wherever the view goes.
function fitFarPlane() {
  const distance = camera.position.distanceTo(boundingSphere.center) + boundingSphere.radius;
  camera.far = Math.max(distance * 1.5, camera.near * 10);
  camera.updateProjectionMatrix();
}

function aspect() {
  return canvas.clientWidth / Math.max(1, canvas.clientHeight);
}

function setAspect(target) {
  if (target.isPerspectiveCamera) {
    target.aspect = aspect();
  } else if (target.isOrthographicCamera) {
    const ymag = (target.top - target.bottom) / 2;
    target.left = -ymag * aspect();
    target.right = ymag * aspect();
  }
  target.updateProjectionMatrix();
}

function attachControls(target, orbitCentre) {
  controls?.dispose();
  camera = target;
  controls = new OrbitControls(camera, canvas);
  controls.target.copy(orbitCentre);
  controls.update();
  controls.addEventListener('change', requestFrame);
}

// A free camera where the file's first camera is (its world transform, its projection); the
// orbit centre lies on its line of sight, at the depth of the scene's centre.
function useFileCamera() {
  if (!fileCamera) return false;
  const view = fileCamera.clone(false);
  fileCamera.updateWorldMatrix(true, false);
  const scale = new THREE.Vector3();
  fileCamera.matrixWorld.decompose(view.position, view.quaternion, scale);
  view.up.set(0, 1, 0).applyQuaternion(view.quaternion);
  view.updateMatrixWorld(true);
  setAspect(view);
  const forward = new THREE.Vector3(0, 0, -1).applyQuaternion(view.quaternion);
  const along = boundingSphere.center.clone().sub(view.position).dot(forward);
  const distance = along > view.near * 10 ? along : boundingSphere.radius;
  fitFar = !fileCameraHasFar;
  attachControls(view, view.position.clone().addScaledVector(forward, distance));
  return true;
}

// Without a camera in the file: the bounding box's whole sphere in view, from +z (the front of a
// glTF model), as Penumbra's own default camera sees a scene.
function frameBounds() {
  const view = new THREE.PerspectiveCamera(45, aspect(), 0.01, 100);
  const distance = boundingSphere.radius / Math.sin(THREE.MathUtils.degToRad(view.fov / 2));
  view.position.copy(boundingSphere.center).add(new THREE.Vector3(0, 0, distance));
  view.near = Math.max(distance - boundingSphere.radius, distance * 1e-3) * 0.5;
  view.updateProjectionMatrix();
  fitFar = true;
  attachControls(view, boundingSphere.center);
}

function setExposure(x) {
  renderer.toneMappingExposure = x;
  const stops = Math.log2(x);
  exposureSlider.value = String(Math.min(EXPOSURE_MAX_STOPS, Math.max(EXPOSURE_MIN_STOPS, stops)));
  exposureValue.textContent = `2^${stops.toFixed(2)} = ${x.toPrecision(3)}`;
}

exposureSlider.min = String(EXPOSURE_MIN_STOPS);
exposureSlider.max = String(EXPOSURE_MAX_STOPS);
exposureSlider.addEventListener('input', () => {
  if (!renderer) return;
  setExposure(2 ** Number(exposureSlider.value));
  requestFrame();
});

window.addEventListener('resize', () => {
  if (!renderer) return;
  renderer.setSize(window.innerWidth, window.innerHeight, false);
  setAspect(camera);
  requestFrame();
});

// ---------------------------------------------------------------------------------------------
// Loading.

async function chooseFile() {
  const named = params.get('gltf');
  if (named) return named;
  const response = await fetch('bake.json');
  if (!response.ok) {
    throw new Error(`no ?gltf=FILE.gltf given, and bake.json beside the page: HTTP ${response.status}`);
  }
  const manifest = await response.json();
  const entry = Array.isArray(manifest.gltf) ? manifest.gltf[0] : manifest.gltf;
  if (typeof entry !== 'string' || !entry) throw new Error('bake.json names no "gltf" file');
  return entry;
}

function loadGltf(url) {
  return new Promise((resolve, reject) => {
    const loader = new GLTFLoader();
    loader.register((parser) => new PenumbraLightmapPlugin(parser));
    loader.load(url, resolve, undefined, (error) => reject(
      error instanceof Error ? error : new Error(String(error?.message ?? error))));
  });
}

async function main() {
  let name = '';
  try {
    name = await chooseFile();
    setStatus(`loading ${name}...`);
    const gltfUrl = new URL(name, window.location.href).href;
    const gltf = await loadGltf(gltfUrl);
    const root = gltf.scene ?? gltf.scenes?.[0];
    if (!root) throw new Error('the file has no scene');
    scene.add(root);
    root.updateMatrixWorld(true);

    // Lights already in the lightmap would count twice.
    const lightsBaked = gltf.parser.json.asset?.extras?.penumbra?.lights_baked === true;
    const lights = [];
    root.traverse((object) => { if (object.isLight) lights.push(object); });
    if (lightsBaked) lights.forEach((light) => light.removeFromParent());

    const lightmaps = await applyLightmaps(renderer, gltf, gltfUrl);

    bounds.setFromObject(root);
    if (bounds.isEmpty()) throw new Error('the scene has no geometry');
    bounds.getBoundingSphere(boundingSphere);
    boundingSphere.radius = Math.max(boundingSphere.radius, 1e-6);

    fileCamera = gltf.cameras?.find((c) => {
      for (let o = c; o; o = o.parent) if (o === root) return true;
      return false;
    }) ?? null;
    if (!fileCamera) root.traverse((object) => { if (!fileCamera && object.isCamera) fileCamera = object; });
    if (fileCamera) {
      const index = gltf.cameras.indexOf(fileCamera);
      const def = gltf.parser.json.cameras?.[Math.max(0, index)];
      fileCameraHasFar = def?.[def?.type]?.zfar !== undefined;
      useFileCamera();
    } else {
      frameBounds();
    }

    const given = Number(params.get('exposure'));
    const automatic = lightmaps.logAverageRadiance > 0 ? 0.18 / lightmaps.logAverageRadiance : 1;
    setExposure(params.has('exposure') && given > 0 ? given : automatic);

    window.penumbraInfo = {
      gltf: name,
      lightmappedMaterials: lightmaps.materials,
      lightmaps: lightmaps.textures,
      camera: fileCamera ? 'file' : 'framed',
      lightsBaked,
      lightsRemoved: lightsBaked ? lights.length : 0,
      lightsKept: lightsBaked ? 0 : lights.length,
    };
    const parts = [`${name}: ${lightmaps.materials} lightmapped material(s)`];
    if (lightmaps.textures.length) {
      const t = lightmaps.textures[0];
      parts.push(`lightmap ${t.width}x${t.height} RGBM (${t.type})`);
    }
    if (lightmaps.materials === 0) parts.push(`no ${EXTENSION}: unlit`);
    parts.push(fileCamera ? 'file camera' : 'framed');
    if (lights.length) parts.push(lightsBaked ? `${lights.length} baked light(s) removed` : `${lights.length} light(s)`);
    setStatus(parts.join(', '));
    await drawFrame();
    window.penumbraReady = true;
  } catch (error) {
    showError(`cannot show ${name || 'the bake'}: ${error.message}`, error);
  }
}

window.penumbraSetExposure = (x) => {
  if (!(typeof x === 'number' && x > 0 && Number.isFinite(x))) {
    throw new Error(`exposure ${x} is not a positive number`);
  }
  setExposure(x);
  return drawFrame();
};

window.penumbraUseFileCamera = async () => {
  const found = useFileCamera();
  await drawFrame();
  return found;
};

if (renderer) main();
