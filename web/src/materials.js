// The viewer's materials: a palette for glTF primitives without a material (the demo
// city names its objects by kind), flat shading where a GLB has no normals, and the
// debug view's colours (occluders blue, drawn white, culled red wireframe).

import * as THREE from "three";

const palette = {
  ground_block: 0x8f9a86,
  ground_street: 0x55595e,
  ground_crossing: 0x676b70,
  ground: 0x8f9a86,
  building_a: 0xd8cbb3,
  building_b: 0xc9b59b,
  building_c: 0xb9c2c9,
  building_d: 0xe0d6c6,
  building_e: 0xa9a39a,
  building_f: 0xcfc0a8,
  building_g: 0xbcb6ae,
  building_h: 0xd3c5b6,
  building: 0xcdbfa9,
  tree: 0x4f7f3a,
  car: 0x8a3b3b,
  bench: 0x7a5a3a,
};
const materialCache = new Map();

export function paletteMaterial(name) {
  const key = String(name || "")
    .toLowerCase()
    .replace(/(_\d+)+$/, "");
  const prefix = Object.keys(palette)
    .filter((k) => key.startsWith(k))
    .sort((a, b) => b.length - a.length)[0];
  const color = prefix ? palette[prefix] : 0xc8c8c8;
  if (!materialCache.has(color)) {
    materialCache.set(color, new THREE.MeshLambertMaterial({ color, flatShading: true, side: THREE.DoubleSide }));
  }
  return materialCache.get(color);
}

export const debugMaterials = {
  occluder: new THREE.MeshLambertMaterial({ color: 0x3f7fe0, flatShading: true, side: THREE.DoubleSide }),
  drawn: new THREE.MeshLambertMaterial({ color: 0xf4f4f4, flatShading: true, side: THREE.DoubleSide }),
  culled: new THREE.MeshBasicMaterial({ color: 0xe02020, wireframe: true, transparent: true, opacity: 0.4, depthTest: false }),
};

// Debug view tints of the levels of detail, level 0 (full detail) first and the last
// colour for level 3 and coarser: drawn objects white, yellow, orange, purple; occluders
// blue, lighter with each level.
const LEVEL_COLORS = [0xf4f4f4, 0xf2d64b, 0xef8a2e, 0x9b59d0];
const OCCLUDER_LEVEL_COLORS = [0x3f7fe0, 0x6fa3f0, 0x9fc4f7, 0xcfe1fb];
const lambert = (color) => new THREE.MeshLambertMaterial({ color, flatShading: true, side: THREE.DoubleSide });
const levelMaterials = LEVEL_COLORS.map(lambert);
const occluderLevelMaterials = OCCLUDER_LEVEL_COLORS.map(lambert);

/** The debug view's material for an object (an occluder when `occluder`) at `level`. */
export function levelMaterial(level, occluder = false) {
  const m = occluder ? occluderLevelMaterials : levelMaterials;
  return m[Math.min(level, m.length - 1)];
}

/**
 * Gives every mesh its drawing material: the palette colour by object name where the
 * glTF has no material, flat-shaded clones where it has no normals, else its own; the
 * choice is kept in `mesh.userData.homcullMaterial` (the debug view swaps materials).
 * `objects` is the object table (names by ID).
 */
export function prepareMaterials(gltf, meshesById, objects) {
  const assoc = gltf.parser.associations;
  meshesById.forEach((meshes, id) => {
    const row = objects[id];
    for (const m of meshes) {
      const hasNormals = Boolean(m.geometry?.attributes?.normal);
      const mats = Array.isArray(m.material) ? m.material : [m.material];
      // GLTFLoader's default material (primitives without one) has no glTF material index;
      // its flat-shaded clones are associated with `undefined`.
      const isDefault = mats.every((mat) => !mat || assoc.get(mat)?.materials === undefined);
      if (isDefault && m.isMesh) {
        m.material = paletteMaterial(row?.name ?? m.name);
      } else if (!hasNormals && m.isMesh) {
        m.material = mats.map((mat) => {
          const key = `flat:${mat.uuid}`;
          if (!materialCache.has(key)) {
            const c = mat.clone();
            c.flatShading = true;
            materialCache.set(key, c);
          }
          return materialCache.get(key);
        });
        if (m.material.length === 1) m.material = m.material[0];
      }
      m.userData.homcullMaterial = m.material;
    }
  });
}
