// meshoptimizer 1.x's simplifyWithAttributes (npm package `meshoptimizer`,
// its WASM simplifier) on a textured OBJ, to a target face count: the peer
// for simplifying across UV seams (bench/seams.py).
//
//   node bench/meshopt1x_attributes.mjs IN.obj OUT.obj TARGET_FACES [UV_WEIGHT]
//
// IN has `v`, `vt` and triangular `f v/vt` lines. Each distinct (v, vt) pair
// of a corner is one vertex of the index buffer, as a renderer would upload
// it, so a UV seam is two vertices at one position: what meshoptimizer
// reads as a seam. The call:
//   simplifyWithAttributes(indices, positions, 3, uvs, 2, [w, w], null,
//                          3 * TARGET_FACES, 1.0, ['LockBorder'])
// w (default 1) weighs the UV error against the position error (both in
// the mesh's units after meshoptimizer's own scaling); target_error 1 is no
// error limit; borders are locked as epsnet keeps boundaries.
// Prints: faces_in faces_out seconds result_error
import { readFileSync, writeFileSync } from 'node:fs';
import { MeshoptSimplifier } from 'meshoptimizer';

const [inPath, outPath, targetArg, weightArg] = process.argv.slice(2);
if (!targetArg) {
	process.stderr.write('usage: node meshopt1x_attributes.mjs IN.obj OUT.obj TARGET_FACES [UV_WEIGHT]\n');
	process.exit(2);
}
const weight = weightArg ? Number(weightArg) : 1;
const pos = [], tex = [], corners = new Map(), vpos = [], vuv = [], idx = [];
for (const line of readFileSync(inPath, 'latin1').split('\n')) {
	const w = line.trim().split(/\s+/);
	if (w[0] === 'v') pos.push([+w[1], +w[2], +w[3]]);
	else if (w[0] === 'vt') tex.push([+w[1], +(w[2] ?? 0)]);
	else if (w[0] === 'f') {
		if (w.length !== 4) throw new Error('only triangles');
		for (const c of w.slice(1)) {
			let k = corners.get(c);
			if (k === undefined) {
				const [a, b] = c.split('/').map(Number);
				k = vpos.length / 3;
				corners.set(c, k);
				vpos.push(...pos[a - 1]);
				vuv.push(...(b ? tex[b - 1] : [0, 0]));
			}
			idx.push(k);
		}
	}
}
await MeshoptSimplifier.ready;
const indices = new Uint32Array(idx);
const t0 = process.hrtime.bigint();
const [out, error] = MeshoptSimplifier.simplifyWithAttributes(
	indices, new Float32Array(vpos), 3, new Float32Array(vuv), 2, [weight, weight], null,
	3 * Number(targetArg), 1.0, ['LockBorder']);
const seconds = Number(process.hrtime.bigint() - t0) / 1e9;
const used = new Map();
let text = '';
for (const k of out)
	if (!used.has(k)) {
		used.set(k, used.size + 1);
		text += `v ${vpos[3 * k]} ${vpos[3 * k + 1]} ${vpos[3 * k + 2]}\nvt ${vuv[2 * k]} ${vuv[2 * k + 1]}\n`;
	}
for (let i = 0; i < out.length; i += 3) {
	const [a, b, c] = [used.get(out[i]), used.get(out[i + 1]), used.get(out[i + 2])];
	text += `f ${a}/${a} ${b}/${b} ${c}/${c}\n`;
}
writeFileSync(outPath, text);
console.log(`${indices.length / 3} ${out.length / 3} ${seconds.toFixed(4)} ${error}`);
