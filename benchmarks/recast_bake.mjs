// Bakes a Recast/Detour navmesh with real Recast (npm @recast-navigation/core + generators 0.43.1,
// the WASM build of recastnavigation) from a triangle file, with habitat-sim's conversion of its
// NavMeshSettings, and writes it with exportNavMesh (the Recast sample's MSET set that habitat-sim
// reads). Used by benchmarks/navmesh_parity.py --bake, which writes the triangle file and runs this
// script from a folder whose node_modules holds the packages (ESM resolves packages from the
// script's own folder, so the script is copied there):
//   mkdir -p R && cd R && npm init -y && npm install @recast-navigation/core@0.43.1 @recast-navigation/generators@0.43.1
//   cp <repo>/benchmarks/recast_bake.mjs R/ && node R/recast_bake.mjs TRIS.bin OUT.navmesh --radius 0.18 --height 1.0
// TRIS.bin: little-endian int32 vertex count, int32 triangle count, float32 xyz per vertex (y up,
// metres), uint32 three indices per triangle. Prints one JSON line: polygons, tiles, bytes.
import { init, exportNavMesh } from '@recast-navigation/core';
import { generateSoloNavMesh } from '@recast-navigation/generators';
import fs from 'fs';

const args = process.argv.slice(2);
const opt = (name, dflt) => {
  const i = args.indexOf(name);
  return i >= 0 ? Number(args[i + 1]) : dflt;
};
const [input, output] = args.filter((a, i) => !a.startsWith('--') && !(i > 0 && args[i - 1].startsWith('--')));
if (!input || !output) {
  console.error('usage: node recast_bake.mjs TRIS.bin OUT.navmesh [--radius 0.18] [--height 1.0] [--climb 0.2]');
  process.exit(2);
}
const radius = opt('--radius', 0.18), height = opt('--height', 1.0), climb = opt('--climb', 0.2);
await init();
const buf = fs.readFileSync(input);
const nv = buf.readInt32LE(0), nt = buf.readInt32LE(4);
if (buf.length !== 8 + nv * 12 + nt * 12) {
  console.error(`${input}: ${buf.length} bytes, expected ${8 + nv * 12 + nt * 12} for ${nv} vertices, ${nt} triangles`);
  process.exit(2);
}
const positions = Array.from(new Float32Array(buf.buffer.slice(buf.byteOffset + 8, buf.byteOffset + 8 + nv * 12)));
const indices = Array.from(new Uint32Array(buf.buffer.slice(buf.byteOffset + 8 + nv * 12, buf.byteOffset + buf.length)));
// habitat-sim's NavMeshSettings defaults (cell 0.05 x 0.2, region 20 / 20, edge 12 m / 1.3, 6 verts per
// poly, detail 6 / 1) converted as its PathFinder does; the generators square the region areas and scale
// the detail settings by cs / ch, as habitat-sim does
const cs = 0.05, ch = 0.2;
const config = {
  cs, ch, walkableSlopeAngle: 45, walkableHeight: Math.ceil(height / ch), walkableClimb: Math.floor(climb / ch),
  walkableRadius: Math.ceil(radius / cs), maxEdgeLen: 12 / cs, maxSimplificationError: 1.3,
  minRegionArea: 20, mergeRegionArea: 20, maxVertsPerPoly: 6, detailSampleDist: 6, detailSampleMaxError: 1,
};
const res = generateSoloNavMesh(positions, indices, config);
if (!res.success) {
  console.error(`${input}: Recast failed: ${res.error}`);
  process.exit(1);
}
const data = exportNavMesh(res.navMesh);
const tmp = `${output}.tmp${process.pid}`;
fs.writeFileSync(tmp, data);
fs.renameSync(tmp, output);
console.log(JSON.stringify({ output, bytes: data.length, vertices: nv, triangles: nt }));
