// Bakes the Recast fixtures tests/data/recast_room_{solo,tiled}.navmesh with real Recast/Detour
// (npm @recast-navigation/core + generators 0.43.1, the WASM build of recastnavigation) and
// writes Detour's own answers for them to tests/data/recast_room.json (detail-mesh area, path
// lengths between fixed points with Habitat's 2048-node query). The files are the Recast
// sample's MSET set (version 1), as habitat-sim also reads them.
//   npm install @recast-navigation/core@0.43.1 @recast-navigation/generators@0.43.1   (in a scratch folder)
//   cp <repo>/tests/data/make_recast_navmesh.mjs . && node make_recast_navmesh.mjs <repo>/tests/data
// Scene: a 4 x 4 m room (walls 4 m high) split by a wall with a 1 m door at z = 3..4, a 0.1 m
// platform (climbable) and a slab 2.4 m up over one corner (a second storey, its own island).
// Settings: habitat-sim's conversion of its defaults with agent radius 0.18 m, height 1.5 m.
import { init, exportNavMesh, NavMeshQuery, getNavMeshPositionsAndIndices } from '@recast-navigation/core';
import { generateSoloNavMesh, generateTiledNavMesh } from '@recast-navigation/generators';
import fs from 'fs';
import path from 'path';

await init();
const out = process.argv[2];
const boxes = [
  [[-0.1, -0.1, -0.1], [4.1, 0.0, 4.1]],                       // floor, top at y = 0
  [[-0.1, 0, -0.1], [0, 4, 4.1]], [[4, 0, -0.1], [4.1, 4, 4.1]], // walls
  [[-0.1, 0, -0.1], [4.1, 4, 0]], [[-0.1, 0, 4], [4.1, 4, 4.1]],
  [[1.9, 0, 0], [2.1, 4, 3]],                                    // dividing wall, door at z = 3..4
  [[2.6, 0, 0.4], [3.6, 0.1, 1.4]],                              // platform 0.1 m high
  [[0.0, 2.3, 0.0], [1.8, 2.4, 1.8]],                            // slab 2.4 m up
];
const positions = [], indices = [];
for (const [lo, hi] of boxes) {
  const b = positions.length / 3;
  for (let i = 0; i < 8; i++) positions.push(i & 1 ? hi[0] : lo[0], i & 2 ? hi[1] : lo[1], i & 4 ? hi[2] : lo[2]);
  // 12 triangles, outward (counter-clockwise seen from outside; Recast keeps upward faces)
  const q = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
  for (const [a, c, d, e] of q) indices.push(b + a, b + c, b + d, b + a, b + d, b + e);
}
const cs = 0.05, ch = 0.2;
const config = {
  cs, ch, walkableSlopeAngle: 45, walkableHeight: Math.ceil(1.5 / ch), walkableClimb: Math.floor(0.2 / ch),
  walkableRadius: Math.ceil(0.18 / cs), maxEdgeLen: 12 / cs, maxSimplificationError: 1.3,
  minRegionArea: 20, mergeRegionArea: 20, maxVertsPerPoly: 6, // the generators square these and scale the
  detailSampleDist: 6, detailSampleMaxError: 1,                 // detail ones by cs / ch, as habitat-sim does
};
const pairs = [[[0.5, 0, 0.5], [3.5, 0, 0.5]], [[0.5, 0, 3.5], [3.5, 0, 3.5]], [[1.0, 0, 0.3], [3.1, 0.1, 0.9]],
               [[0.4, 0, 2.5], [3.5, 0, 2.0]], [[3.0, 0.1, 1.0], [3.8, 0, 3.8]], [[0.9, 2.4, 0.9], [1.3, 2.4, 1.4]],
               [[0.5, 0, 0.5], [0.9, 2.4, 0.9]]];
const reference = { pairs, files: {} };
for (const [name, gen, extra] of [['solo', generateSoloNavMesh, {}], ['tiled', generateTiledNavMesh, { tileSize: 32 }]]) {
  const res = gen(positions, indices, { ...config, ...extra });
  if (!res.success) throw new Error(`${name}: ${res.error}`);
  const file = `recast_room_${name}.navmesh`;
  fs.writeFileSync(path.join(out, file), exportNavMesh(res.navMesh));
  const [pos, idx] = getNavMeshPositionsAndIndices(res.navMesh);
  let area = 0;
  for (let t = 0; t < idx.length; t += 3) {
    const a = idx[t] * 3, b = idx[t + 1] * 3, c = idx[t + 2] * 3;
    area += 0.5 * Math.abs((pos[b] - pos[a]) * (pos[c + 2] - pos[a + 2]) - (pos[c] - pos[a]) * (pos[b + 2] - pos[a + 2]));
  }
  const query = new NavMeshQuery(res.navMesh, { maxNodes: 2048 });
  const lengths = pairs.map(([a, b]) => {
    const r = query.computePath({ x: a[0], y: a[1], z: a[2] }, { x: b[0], y: b[1], z: b[2] },
                                { halfExtents: { x: 0.3, y: 0.6, z: 0.3 } });
    const end = r.path[r.path.length - 1];
    if (!r.success || !end || Math.hypot(end.x - b[0], end.z - b[2]) > 0.05 || Math.abs(end.y - b[1]) > 0.5) return null;  // no or partial path
    let d = 0;
    for (let i = 1; i < r.path.length; i++) d += Math.hypot(r.path[i].x - r.path[i - 1].x, r.path[i].y - r.path[i - 1].y, r.path[i].z - r.path[i - 1].z);
    return d;
  });
  reference.files[file] = { area: +area.toFixed(6), lengths: lengths.map((d) => (d === null ? null : +d.toFixed(6))) };
}
fs.writeFileSync(path.join(out, 'recast_room.json'), JSON.stringify(reference, null, 1) + '\n');
console.log(JSON.stringify(reference));
