// An engine's loader for a `shvis export` folder, written against the export's files alone
// (manifest.json, scene.gltf, the KTX2 files, params.bin, decode.glsl) with three.js:
//
// - the scene through GLTFLoader, drawn from the glTF's camera;
// - each KTX2 file through ktx-parse into a three.js array texture (RGBA16F/R16F/RGBA8/R8 as
//   a DataArrayTexture; BC7, BC6H and BC4 as a CompressedArrayTexture through
//   EXT_texture_compression_bptc / _rgtc), with the manifest's orientation and filtering;
// - the technique's fragment shader, decode.glsl, turned from Vulkan GLSL into GLSL ES 3.00
//   (uniform blocks become uniform structs, `layout(binding)` goes) and bound by the
//   manifest: its bindings name which texture each sampler reads, its uniform block's
//   fields give the values, its inputs name the glTF attribute each varying carries;
// - or, with shading=manifest, a fragment shader written from the manifest's value map
//   alone (manifestShader), for the SH, H-basis and spherical Gaussian techniques.
//
// The page renders into a float target (linear radiance, as shvis' renderer writes it),
// reads it back and POSTs it to its server: /pixels (RGBA f32, the top row first), then the
// world position, the vertex normal and the normal map's bitangent (its frame's handedness
// included) each pixel sees (/positions, /normals, /bitangents, the same layout), then /done with what the browser offered ({renderer, bptc, rgtc}). Any failure
// POSTs /error.
//
// Query: ?export=URL-of-the-folder&width=W&height=H[&shading=manifest]
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { read } from 'ktx-parse';

const query = new URLSearchParams(location.search);
const base = (query.get('export') ?? 'export').replace(/\/$/, '') + '/';
const width = Number(query.get('width') ?? 640);
const height = Number(query.get('height') ?? 400);
// shading=manifest: shade from the manifest's value map alone (manifestShader), not from
// decode.glsl.
const fromManifest = query.get('shading') === 'manifest';

async function bytes(name) {
  const response = await fetch(base + name);
  if (!response.ok) throw new Error(`${name}: HTTP ${response.status}`);
  return new Uint8Array(await response.arrayBuffer());
}

// Vulkan formats (VkFormat values, as KTX2's vkFormat) this page uploads.
const VK = {
  R8_UNORM: 9,
  R8G8B8A8_UNORM: 37,
  R16_SFLOAT: 76,
  R16G16B16A16_SFLOAT: 97,
  BC4_UNORM_BLOCK: 139,
  BC6H_UFLOAT_BLOCK: 143,
  BC7_UNORM_BLOCK: 145,
};

// One KTX2 file as a three.js 2D array texture, sampled as the manifest says: bilinear,
// clamped to the edge, one level, no colour transfer, no flip ("rd": texel (0, 0) at uv (0, 0)).
function arrayTexture(file, container, lightmap) {
  if (container.supercompressionScheme !== 0) throw new Error(`${file}: supercompressed`);
  if (container.faceCount !== 1) throw new Error(`${file}: a cube map (this page reads 2D arrays)`);
  const orientation = container.keyValue.KTXorientation;
  if (orientation !== lightmap.orientation) {
    throw new Error(`${file}: KTXorientation ${orientation}, the manifest says ${lightmap.orientation}`);
  }
  const { pixelWidth: w, pixelHeight: h } = container;
  const layers = Math.max(1, container.layerCount);
  const level = container.levels[0].levelData;
  const copy = level.slice();
  let texture;
  const compressed = (format) =>
    new THREE.CompressedArrayTexture([{ data: copy, width: w, height: h }], w, h, layers, format);
  switch (container.vkFormat) {
    case VK.R16G16B16A16_SFLOAT:
      texture = new THREE.DataArrayTexture(new Uint16Array(copy.buffer), w, h, layers);
      texture.type = THREE.HalfFloatType;
      texture.format = THREE.RGBAFormat;
      break;
    case VK.R16_SFLOAT:
      texture = new THREE.DataArrayTexture(new Uint16Array(copy.buffer), w, h, layers);
      texture.type = THREE.HalfFloatType;
      texture.format = THREE.RedFormat;
      break;
    case VK.R8_UNORM:
      texture = new THREE.DataArrayTexture(copy, w, h, layers);
      texture.type = THREE.UnsignedByteType;
      texture.format = THREE.RedFormat;
      break;
    case VK.R8G8B8A8_UNORM:
      texture = new THREE.DataArrayTexture(copy, w, h, layers);
      texture.type = THREE.UnsignedByteType;
      texture.format = THREE.RGBAFormat;
      break;
    case VK.BC7_UNORM_BLOCK:
      texture = compressed(THREE.RGBA_BPTC_Format);
      break;
    case VK.BC6H_UFLOAT_BLOCK:
      texture = compressed(THREE.RGB_BPTC_UNSIGNED_Format);
      break;
    case VK.BC4_UNORM_BLOCK:
      texture = compressed(THREE.RED_RGTC1_Format);
      break;
    default:
      throw new Error(`${file}: vkFormat ${container.vkFormat} is not one this page uploads`);
  }
  texture.colorSpace = THREE.NoColorSpace;
  texture.flipY = false;
  texture.generateMipmaps = false;
  texture.minFilter = THREE.LinearFilter;
  texture.magFilter = THREE.LinearFilter;
  texture.wrapS = THREE.ClampToEdgeWrapping;
  texture.wrapT = THREE.ClampToEdgeWrapping;
  texture.needsUpdate = true;
  return texture;
}

// decode.glsl (Vulkan GLSL 4.50) as GLSL ES 3.00. Returns the source and every uniform it
// declares ({binding, name, kind: 'block' | 'sampler', block}); declarations in branches
// its #if lines leave out are listed too (the compiler drops them, and so do unused ones).
function toGlslEs(source, bindingValues) {
  const bindings = [];
  const bindingOf = (layout) => {
    const m = /binding\s*=\s*(\w+)/.exec(layout);
    if (!m) throw new Error(`decode.glsl: a uniform without a binding: layout(${layout})`);
    const value = /^\d+$/.test(m[1]) ? Number(m[1]) : bindingValues[m[1]];
    if (value === undefined) throw new Error(`decode.glsl: binding ${m[1]} is not in the manifest`);
    return value;
  };
  let s = source
    .replace(/^\s*#version.*$/m, '')
    .replace(/^\s*#extension.*$/gm, '');
  s = s.replace(
    /layout\s*\(([^)]*)\)\s*uniform\s+(\w+)\s*\{([^}]*)\}\s*(\w+)\s*;/g,
    (_, layout, block, body, instance) => {
      bindings.push({ binding: bindingOf(layout), name: instance, kind: 'block', block });
      const members = body.replace(/layout\s*\([^)]*\)\s*/g, '');
      return `struct ${block} {${members}};\nuniform ${block} ${instance};`;
    },
  );
  s = s.replace(
    /layout\s*\(([^)]*)\)\s*uniform\s+(\w+)\s+(\w+)\s*(\[\s*\w+\s*\])?\s*;/g,
    (_, layout, type, name, array) => {
      bindings.push({ binding: bindingOf(layout), name, kind: 'sampler' });
      return `uniform highp ${type} ${name}${array ?? ''};`;
    },
  );
  s = s.replace(/layout\s*\(\s*location\s*=\s*\d+\s*\)\s*in\s+/g, 'in ');
  const precision = [
    'precision highp float;',
    'precision highp int;',
    'precision highp sampler2D;',
    'precision highp sampler2DArray;',
  ].join('\n');
  return { source: `${precision}\n${s}`, bindings };
}

// The fragment shader an engine writes from the manifest alone, without decode.glsl:
// `per_texel.values` says which coefficient and colour each value is, the basis, and the
// shading steps; `per_texel.codec` how a texel turns into values; `conventions.sh_basis` the
// SH convention. This page knows the bases by name (SH, the H-basis, spherical Gaussians),
// as an engine would; their parameters come from the manifest.
function manifestShader(manifest) {
  const perTexel = manifest.per_texel;
  const values = perTexel.values;
  if (!values) throw new Error(`${manifest.technique}: the manifest has no value map`);
  const steps = values.shading;
  const sh = manifest.conventions.sh_basis;
  if (values.basis.name === 'sh' && (sh.normalisation !== 'orthonormal over the sphere' || !sh.condon_shortley_phase
      || sh.index !== 'l * (l + 1) + m' || sh.pole_axis !== '+Z')) {
    throw new Error('an SH convention this page does not evaluate');
  }
  const total = perTexel.values_per_texel;
  const coefficients = 1 + Math.max(...values.map.map((e) => e.index));
  const lines = [
    'precision highp float;',
    'precision highp sampler2DArray;',
    'in vec3 in_normal_world;',
    'in vec4 in_tangent_world;',
    'in vec2 in_uv_material;',
    'in vec2 in_uv_lightmap;',
    'in vec3 in_albedo_tint;',
    'uniform sampler2D albedo_tex;',
    'uniform sampler2D normal_tex;',
    'uniform float normal_scale;',
    'uniform float unscale;',
    perTexel.files.length > 1 ? 'uniform sampler2DArray per_texel_tex[2];' : 'uniform sampler2DArray per_texel_tex;',
    'layout(location = 0) out vec4 out_radiance;',
    'const float PI = 3.14159265358979;',
    'void main() {',
    // The normal map's tangent-space normal and the world shading normal (glTF frame).
    '  vec3 m = vec3(0.0, 0.0, 1.0);',
    '  if (normal_scale != 0.0) {',
    '    vec3 t = texture(normal_tex, in_uv_material).xyz * 2.0 - 1.0;',
    '    t.xy *= normal_scale;',
    '    m = length(t) > 1e-6 ? normalize(t) : vec3(0.0, 0.0, 1.0);',
    '  }',
    '  vec3 nv = normalize(in_normal_world);',
    '  vec3 tv = in_tangent_world.xyz - nv * dot(nv, in_tangent_world.xyz);',
    '  vec3 n = length(tv) > 1e-6 ? normalize(normalize(tv) * m.x + cross(nv, normalize(tv)) * in_tangent_world.w * m.y + nv * m.z) : nv;',
    `  float v[${total}];`,
  ];
  const layers = total / 4;
  if (perTexel.codec.name === 'plain') {
    for (let g = 0; g < layers; ++g) {
      lines.push(`  { vec4 s = texture(per_texel_tex, vec3(in_uv_lightmap, ${g}.0)); v[${4 * g}] = s.x; v[${4 * g + 1}] = s.y; v[${4 * g + 2}] = s.z; v[${4 * g + 3}] = s.w; }`);
    }
  } else if (perTexel.codec.name === 'ratio-to-norm') {
    const { scale, offset, divisor } = perTexel.codec.constants;
    const f = (x) => Number(x).toFixed(6);
    lines.push('  vec3 norms = texture(per_texel_tex[1], vec3(in_uv_lightmap, 0.0)).rgb;');
    for (let g = 0; g < layers; ++g) {
      lines.push(`  { vec4 s = (texture(per_texel_tex[0], vec3(in_uv_lightmap, ${g}.0)) * ${f(scale)} - ${f(offset)}) / ${f(divisor)};`);
      for (let i = 0; i < 4; ++i) {
        lines.push(`    v[${4 * g + i}] = s[${i}] * norms[${perTexel.codec.norm_colour[4 * g + i]}];`);
      }
      lines.push('  }');
    }
  } else {
    throw new Error(`codec ${perTexel.codec.name}`);
  }
  // Coefficient k of colour c from the map.
  lines.push(`  vec3 c[${coefficients}];`);
  lines.push(`  for (int k = 0; k < ${coefficients}; ++k) c[k] = vec3(0.0);`);
  const channel = { r: 0, g: 1, b: 2 };
  for (const e of values.map) {
    if (!(e.colour in channel)) throw new Error(`colour ${e.colour}: this page maps RGB values only`);
    lines.push(`  c[${e.index}][${channel[e.colour]}] = v[${e.j}];`);
  }
  lines.push('  vec3 e = vec3(0.0);');
  const basis = values.basis;
  const fixed = (x) => Number(x).toFixed(9);
  if (basis.name === 'sh') {
    const convolve = steps.find((s) => s.op === 'convolve');
    if (!convolve) throw new Error('an SH map without its convolution');
    const a = convolve.constants.A_l;
    // Orthonormal real SH, Condon–Shortley phase, index l(l+1)+m, pole on +Z.
    const y = [
      '0.28209479177',
      '-0.4886025119 * n.y', '0.4886025119 * n.z', '-0.4886025119 * n.x',
      '1.0925484306 * n.x * n.y', '-1.0925484306 * n.y * n.z', '0.31539156525 * (3.0 * n.z * n.z - 1.0)',
      '-1.0925484306 * n.x * n.z', '0.54627421529 * (n.x * n.x - n.y * n.y)',
    ];
    if (basis.frame !== 'world' || basis.order > 3 || a.length !== basis.order) throw new Error('an SH basis this page does not evaluate');
    for (let k = 0; k < basis.order * basis.order; ++k) {
      const l = k < 1 ? 0 : k < 4 ? 1 : 2;
      lines.push(`  e += ${fixed(a[l])} * (${y[k]}) * c[${k}];`);
    }
  } else if (basis.name === 'h-basis') {
    const h = [
      '1.0 / sqrt(2.0 * PI)',
      'sqrt(3.0 / (2.0 * PI)) * m.y',
      'sqrt(3.0 / (2.0 * PI)) * (2.0 * m.z - 1.0)',
      'sqrt(3.0 / (2.0 * PI)) * m.x',
      'sqrt(15.0 / (2.0 * PI)) * m.x * m.y',
      '0.5 * sqrt(15.0 / (2.0 * PI)) * (m.x * m.x - m.y * m.y)',
    ];
    for (let i = 0; i < coefficients; ++i) lines.push(`  e += (${h[i]}) * c[${i}];`);
  } else if (basis.name === 'spherical gaussians') {
    // Each lobe's integral against the clamped cosine (Hill's fit, the manifest's formula).
    const lambda = fixed(basis.sharpness);
    lines.push(`  float lambda = ${lambda};`);
    lines.push('  float ex = exp(-lambda), ex2 = ex * ex, r = 1.0 / lambda;');
    lines.push('  float scale = 1.0 + 2.0 * ex2 - r, bias = (ex - ex2) * r - ex2;');
    lines.push('  float x = sqrt(max(1.0 - scale, 0.0)), x1 = x / (4.0 * 0.36);');
    lines.push('  float integral = 2.0 * PI * (1.0 - exp(-2.0 * lambda)) * r;');
    basis.axes.forEach((axis, k) => {
      lines.push(`  { float t = dot(vec3(${axis.map(fixed).join(', ')}), m); float x0 = 0.36 * t;`);
      lines.push('    float y = abs(x0) <= x1 ? (x0 + x1) * (x0 + x1) / x : clamp(t, 0.0, 1.0);');
      lines.push(`    e += c[${k}] * (scale * y + bias) * integral; }`);
    });
  } else {
    throw new Error(`basis ${basis.name}: this page does not evaluate it from the manifest`);
  }
  for (const step of steps) {
    if (step.op === 'multiply' && step.by === 'uniform_block.unscale.x') lines.push('  e *= unscale;');
    else if (step.op === 'max') lines.push(`  e = max(e, vec3(${fixed(step.with)}));`);
    else if (step.op === 'multiply' && step.by === 'albedo / pi') {
      lines.push('  vec3 albedo = texture(albedo_tex, in_uv_material).rgb * in_albedo_tint;');
      lines.push('  out_radiance = vec4(albedo / PI * e, 1.0);');
    } else if (step.op !== 'convolve' && step.op !== 'evaluate') {
      throw new Error(`shading step ${JSON.stringify(step)}: this page does not apply it`);
    }
  }
  lines.push('}');
  return lines.join('\n');
}

// The vertex stage the manifest's inputs ask for: each varying the glTF attribute it
// carries, in world space.
const THREE_ATTRIBUTE = {
  POSITION: 'position',
  NORMAL: 'normal',
  TANGENT: 'tangent',
  TEXCOORD_0: 'uv',
  TEXCOORD_1: 'uv1',
  COLOR_0: 'color',
};
function vertexShader(inputs) {
  const lines = [
    'precision highp float;',
    'uniform mat4 modelMatrix;',
    'uniform mat4 viewMatrix;',
    'uniform mat4 projectionMatrix;',
    'in vec3 position;',
  ];
  const body = [];
  const declared = new Set(['position']);
  for (const input of inputs) {
    const attribute = THREE_ATTRIBUTE[input.gltf];
    if (!attribute) throw new Error(`input ${input.name}: glTF attribute ${input.gltf} unknown`);
    const type = { NORMAL: 'vec3', TANGENT: 'vec4', TEXCOORD_0: 'vec2', TEXCOORD_1: 'vec2', COLOR_0: 'vec3', POSITION: 'vec3' }[input.gltf];
    if (!declared.has(attribute)) {
      lines.push(`in ${type} ${attribute};`);
      declared.add(attribute);
    }
    lines.push(`out ${input.type} ${input.name};`);
    let value = attribute;
    if (input.gltf === 'NORMAL') value = `mat3(modelMatrix) * ${attribute}`;
    if (input.gltf === 'TANGENT') value = `vec4(mat3(modelMatrix) * ${attribute}.xyz, ${attribute}.w)`;
    if (input.gltf === 'POSITION') value = `(modelMatrix * vec4(${attribute}, 1.0)).xyz`;
    body.push(`  ${input.name} = ${value};`);
  }
  return [
    ...lines,
    'void main() {',
    ...body,
    '  gl_Position = projectionMatrix * viewMatrix * modelMatrix * vec4(position, 1.0);',
    '}',
  ].join('\n');
}

// The uniform block's values, from the manifest's fields, as three.js struct values.
function blockValue(block) {
  const value = {};
  for (const field of block.fields) {
    const element = (v) => {
      if (typeof v === 'number') return v;
      if (v.length === 4) return new THREE.Vector4(...v);
      if (v.length === 3) return new THREE.Vector3(...v);
      if (v.length === 2) return new THREE.Vector2(...v);
      if (v.length === 16) return new THREE.Matrix4().fromArray(v);
      throw new Error(`field ${field.name}: ${v.length} components`);
    };
    const values = field.values.map(element);
    value[field.name] = field.count > 1 || field.array_stride !== null ? values : values[0];
  }
  return value;
}

async function run() {
  const manifest = await (await fetch(base + 'manifest.json')).json();
  if (manifest.manifest_version !== 2) throw new Error(`manifest_version ${manifest.manifest_version}`);
  if (manifest.tables.length) throw new Error('this page reads per-texel data only, not tables');
  const canvas = document.getElementById('view');
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: false });
  renderer.setPixelRatio(1);
  renderer.setSize(width, height, false);
  const gl = renderer.getContext();
  const shaderErrors = [];
  renderer.debug.onShaderError = (context, program, vertex, fragment) => {
    shaderErrors.push(
      `vertex: ${context.getShaderInfoLog(vertex)}\nfragment: ${context.getShaderInfoLog(fragment)}\nprogram: ${context.getProgramInfoLog(program)}`,
    );
  };
  const bptc = Boolean(gl.getExtension('EXT_texture_compression_bptc'));
  const rgtc = Boolean(gl.getExtension('EXT_texture_compression_rgtc'));
  const debug = gl.getExtension('WEBGL_debug_renderer_info');
  const info = {
    renderer: debug ? gl.getParameter(debug.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER),
    bptc,
    rgtc,
  };

  const gltf = await new GLTFLoader().loadAsync(base + manifest.geometry.gltf);
  const camera = gltf.cameras[0];
  if (!camera) throw new Error('the glTF has no camera');
  camera.aspect = width / height;
  camera.updateProjectionMatrix();
  gltf.scene.updateMatrixWorld(true);

  const perTexel = [];
  for (const entry of manifest.per_texel.files) {
    const container = read(await bytes(entry.file));
    perTexel.push(arrayTexture(entry.file, container, manifest.lightmap));
  }
  const decode = new TextDecoder().decode(await bytes(manifest.shader.file));
  const { source, bindings } = toGlslEs(decode, manifest.shader.bindings);
  const binding = (name) => manifest.shader.bindings[`SHVIS_BINDING_${name}`];

  const gltfMaterial = gltf.parser.json.materials[0];
  const normalScale = gltfMaterial.normalTexture ? gltfMaterial.normalTexture.scale ?? 1 : 0;
  const uniforms = {};
  let meshMaterial = null;
  gltf.scene.traverse((o) => {
    if (o.isMesh && !meshMaterial) meshMaterial = o.material;
  });
  if (!meshMaterial) throw new Error('the glTF has no mesh');
  // Each uniform by the manifest's binding numbers; bindings of features this export does
  // not use (the specular material term) stay unbound: their declarations sit in branches
  // the shader's #if lines leave out.
  for (const uniform of bindings) {
    const number = uniform.binding;
    if (number === binding('FRAME')) {
      // The frame block: what the vertex stage and the view need are three.js' own; the
      // fragment stage reads normal_scale (glTF normalTexture.scale).
      const clip = new THREE.Matrix4().multiplyMatrices(camera.projectionMatrix, camera.matrixWorldInverse);
      const eye = new THREE.Vector3().setFromMatrixPosition(camera.matrixWorld);
      uniforms[uniform.name] = {
        value: { clip_from_world: clip, camera_position: new THREE.Vector4(eye.x, eye.y, eye.z, 1), normal_scale: normalScale },
      };
    } else if (number === binding('ALBEDO')) {
      uniforms[uniform.name] = { value: meshMaterial.map };
    } else if (number === binding('NORMAL_MAP')) {
      uniforms[uniform.name] = { value: meshMaterial.normalMap };
    } else if (number === binding('TECHNIQUE_PARAMS')) {
      if (uniform.block !== manifest.uniform_block.block) {
        throw new Error(`block ${uniform.block}, the manifest spells out ${manifest.uniform_block.block}`);
      }
      uniforms[uniform.name] = { value: blockValue(manifest.uniform_block) };
    } else if (number === binding('TECHNIQUE_TEXTURE0')) {
      // One file: one array texture; more (dx11's ratios and norms): an array of them.
      uniforms[uniform.name] = { value: perTexel.length > 1 ? perTexel : perTexel[0] };
    }
  }
  const unscaleField = manifest.uniform_block.fields.find((f) => f.name === 'unscale');
  const material = fromManifest
    ? new THREE.RawShaderMaterial({
      name: 'manifest',
      glslVersion: THREE.GLSL3,
      vertexShader: vertexShader(manifest.shader.inputs),
      fragmentShader: manifestShader(manifest),
      uniforms: {
        albedo_tex: { value: meshMaterial.map },
        normal_tex: { value: meshMaterial.normalMap },
        normal_scale: { value: normalScale },
        unscale: { value: unscaleField ? unscaleField.values[0][0] : 1 },
        per_texel_tex: { value: perTexel.length > 1 ? perTexel : perTexel[0] },
      },
      side: meshMaterial.side,
    })
    : new THREE.RawShaderMaterial({
      name: 'decode.glsl',
      glslVersion: THREE.GLSL3,
      vertexShader: vertexShader(manifest.shader.inputs),
      fragmentShader: source,
      uniforms,
      side: meshMaterial.side,
    });
  const target = new THREE.WebGLRenderTarget(width, height, {
    type: THREE.FloatType,
    format: THREE.RGBAFormat,
    depthBuffer: true,
  });
  // One image of the scene drawn with `drawn`, read back top row first (WebGL reads the
  // bottom row first).
  const image = (drawn) => {
    gltf.scene.traverse((o) => {
      if (o.isMesh) o.material = drawn;
    });
    renderer.setRenderTarget(target);
    renderer.setClearColor(0x000000, 0);
    renderer.clear();
    renderer.render(gltf.scene, camera);
    if (shaderErrors.length) throw new Error(shaderErrors.join('\n'));
    const pixels = new Float32Array(width * height * 4);
    renderer.readRenderTargetPixels(target, 0, 0, width, height, pixels);
    const flipped = new Float32Array(pixels.length);
    const row = width * 4;
    for (let y = 0; y < height; ++y) {
      flipped.set(pixels.subarray((height - 1 - y) * row, (height - y) * row), y * row);
    }
    return flipped;
  };
  // What each pixel sees, for the comparison to tell the pixels where two rasterizers hit
  // different surfaces: the world position, the interpolated vertex normal and the normal
  // map's bitangent w · cross(n, t) (the frame common.glsl's tangent_frame builds).
  const seen = (value) =>
    new THREE.RawShaderMaterial({
      glslVersion: THREE.GLSL3,
      vertexShader: [
        'precision highp float;',
        'uniform mat4 modelMatrix;',
        'uniform mat4 viewMatrix;',
        'uniform mat4 projectionMatrix;',
        'in vec3 position;',
        'in vec3 normal;',
        'in vec4 tangent;',
        'out vec3 world_position;',
        'out vec3 world_normal;',
        'out vec4 world_tangent;',
        'void main() {',
        '  world_position = (modelMatrix * vec4(position, 1.0)).xyz;',
        '  world_normal = mat3(modelMatrix) * normal;',
        '  world_tangent = vec4(mat3(modelMatrix) * tangent.xyz, tangent.w);',
        '  gl_Position = projectionMatrix * viewMatrix * vec4(world_position, 1.0);',
        '}',
      ].join('\n'),
      fragmentShader: [
        'precision highp float;',
        'in vec3 world_position;',
        'in vec3 world_normal;',
        'in vec4 world_tangent;',
        'layout(location = 0) out vec4 out_value;',
        'void main() {',
        '  vec3 n = normalize(world_normal);',
        '  vec3 t = world_tangent.xyz - n * dot(n, world_tangent.xyz);',
        '  vec3 bitangent = length(t) > 1e-6 ? cross(n, normalize(t)) * world_tangent.w : vec3(0.0);',
        `  out_value = vec4(${value}, 1.0);`,
        '}',
      ].join('\n'),
      side: meshMaterial.side,
    });
  const radiance = image(material);
  const positions = image(seen('world_position'));
  const normals = image(seen('n'));
  const bitangents = image(seen('bitangent'));
  renderer.setRenderTarget(null);
  renderer.render(gltf.scene, camera);
  const errorCheck = gl.getError();
  if (errorCheck !== gl.NO_ERROR) throw new Error(`WebGL error ${errorCheck}`);
  await fetch('/pixels', { method: 'POST', body: radiance.buffer });
  await fetch('/positions', { method: 'POST', body: positions.buffer });
  await fetch('/normals', { method: 'POST', body: normals.buffer });
  await fetch('/bitangents', { method: 'POST', body: bitangents.buffer });
  await fetch('/done', { method: 'POST', body: JSON.stringify(info) });
}

run().catch(async (e) => {
  await fetch('/error', { method: 'POST', body: String(e && e.stack ? e.stack : e) });
});
