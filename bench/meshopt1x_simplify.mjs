// meshoptimizer 1.x (npm package `meshoptimizer`, its WASM simplifier) on a
// mesh, to a target face count: the second peer of bench/quality_by_ratio.py.
//
//   node bench/meshopt1x_simplify.mjs IN OUT.obj TARGET_FACES [--update]
//
// IN is a binary little-endian PLY (as `epsnet convert IN -o X.ply --float32`
// writes it) or an OBJ (v and f lines; polygons are fanned). The call mirrors
// bench/peer_meshopt.c (meshopt_simplify of meshoptimizer 0.18):
//   MeshoptSimplifier.simplify(indices, positions, 3, 3 * TARGET_FACES,
//                              1.0, ['LockBorder'])
// target_error 1 (relative to the mesh extent) means "no error limit", so the
// face count alone stops it; borders are locked as epsnet locks boundary
// vertices. No other flag (no Prune, no Regularize, no Permissive).
// The output keeps the referenced vertices in their input order (as
// peer_meshopt compacts), written as OBJ.
//
// --update calls simplifyWithUpdate instead (same flags, no attributes): the
// same simplifier, but each kept vertex moves to its quadric's best position,
// as Open3D and MeshLab place theirs (so later costs follow the moved ones). epsnet keeps input vertices (SPEC), so
// this shows what placement alone is worth (bench/RESULTS.md, session 24).
//
// Prints one line: faces_in faces_out seconds peak_rss_bytes result_error
// version, where seconds is the simplify call alone and peak_rss_bytes the
// process high-water mark (node and the WASM heap included).
import { readFileSync, writeFileSync, renameSync } from 'node:fs';
import { createRequire } from 'node:module';
import { dirname, join } from 'node:path';
import { MeshoptSimplifier } from 'meshoptimizer';

function die(message) {
	process.stderr.write(`meshopt1x_simplify: ${message}\n`);
	process.exit(1);
}

const SIZES = {
	char: 1, int8: 1, uchar: 1, uint8: 1,
	short: 2, int16: 2, ushort: 2, uint16: 2,
	int: 4, int32: 4, uint: 4, uint32: 4, float: 4, float32: 4,
	double: 8, float64: 8,
};

function getter(view, type) {
	switch (type) {
	case 'char': case 'int8': return (o) => view.getInt8(o);
	case 'uchar': case 'uint8': return (o) => view.getUint8(o);
	case 'short': case 'int16': return (o) => view.getInt16(o, true);
	case 'ushort': case 'uint16': return (o) => view.getUint16(o, true);
	case 'int': case 'int32': return (o) => view.getInt32(o, true);
	case 'uint': case 'uint32': return (o) => view.getUint32(o, true);
	case 'float': case 'float32': return (o) => view.getFloat32(o, true);
	case 'double': case 'float64': return (o) => view.getFloat64(o, true);
	default: die(`PLY property type '${type}' not supported`);
	}
}

function readPly(buf) {
	const marker = buf.indexOf('end_header');
	if (marker < 0) die('PLY without end_header');
	let body = buf.indexOf(0x0a, marker) + 1;
	const header = buf.subarray(0, body).toString('latin1').split(/\r?\n/);
	if (!header.some((l) => l.startsWith('format binary_little_endian')))
		die('only binary little-endian PLY is read (epsnet convert IN -o X.ply writes it)');
	const elements = [];
	for (const line of header) {
		const w = line.trim().split(/\s+/);
		if (w[0] === 'element') elements.push({ name: w[1], count: Number(w[2]), props: [] });
		else if (w[0] === 'property') {
			const el = elements[elements.length - 1];
			if (w[1] === 'list') el.props.push({ name: w[4], list: true, countType: w[2], type: w[3] });
			else el.props.push({ name: w[2], list: false, type: w[1] });
		}
	}
	const view = new DataView(buf.buffer, buf.byteOffset, buf.byteLength);
	let off = body;
	let positions = null;
	let faces = [];
	for (const el of elements) {
		if (el.name === 'vertex') {
			positions = new Float32Array(el.count * 3);
			const axes = ['x', 'y', 'z'].map((a) => el.props.findIndex((p) => p.name === a));
			if (axes.some((i) => i < 0)) die('PLY vertex without x, y, z');
			if (el.props.some((p) => p.list)) die('PLY vertex with a list property');
			const offs = [];
			let stride = 0;
			for (const p of el.props) { offs.push(stride); stride += SIZES[p.type]; }
			const get = axes.map((i) => getter(view, el.props[i].type));
			for (let v = 0; v < el.count; v++, off += stride)
				for (let k = 0; k < 3; k++) positions[3 * v + k] = get[k](off + offs[axes[k]]);
		} else if (el.name === 'face') {
			const tri = new Uint32Array(el.count * 3);
			let nt = 0;
			let out = tri;
			for (let f = 0; f < el.count; f++) {
				for (const p of el.props) {
					if (!p.list) { off += SIZES[p.type]; continue; }
					const n = getter(view, p.countType)(off);
					off += SIZES[p.countType];
					const gi = getter(view, p.type);
					const size = SIZES[p.type];
					if (p.name !== 'vertex_indices' && p.name !== 'vertex_index') { off += n * size; continue; }
					const first = gi(off);
					for (let k = 1; k + 1 < n; k++) {
						if (3 * nt + 3 > out.length) {
							const grown = new Uint32Array(out.length * 2 + 3);
							grown.set(out);
							out = grown;
						}
						out[3 * nt] = first;
						out[3 * nt + 1] = gi(off + k * size);
						out[3 * nt + 2] = gi(off + (k + 1) * size);
						nt++;
					}
					off += n * size;
				}
			}
			faces = out.subarray(0, 3 * nt);
		} else {
			// other elements: skip fixed-size ones only
			if (el.props.some((p) => p.list)) die(`PLY element '${el.name}' with lists is not supported`);
			let stride = 0;
			for (const p of el.props) stride += SIZES[p.type];
			off += stride * el.count;
		}
	}
	if (!positions) die('PLY without vertices');
	return { positions, indices: Uint32Array.from(faces) };
}

function readObj(text) {
	const pos = [];
	const idx = [];
	for (const line of text.split('\n')) {
		if (line.startsWith('v ')) {
			const w = line.trim().split(/\s+/);
			pos.push(Number(w[1]), Number(w[2]), Number(w[3]));
		} else if (line.startsWith('f ')) {
			const w = line.trim().split(/\s+/).slice(1).map((s) => {
				const i = parseInt(s, 10);
				return i < 0 ? pos.length / 3 + i : i - 1;
			});
			for (let k = 1; k + 1 < w.length; k++) idx.push(w[0], w[k], w[k + 1]);
		}
	}
	return { positions: Float32Array.from(pos), indices: Uint32Array.from(idx) };
}

const args = process.argv.slice(2);
const update = args[3] === '--update';
if (args.length !== 3 && !(args.length === 4 && update))
	die('usage: node meshopt1x_simplify.mjs IN OUT.obj TARGET_FACES [--update]');
const [input, output, targetText] = args;
const targetFaces = Number(targetText);
if (!Number.isInteger(targetFaces) || targetFaces < 0) die(`bad TARGET_FACES '${targetText}'`);

const buf = readFileSync(input);
const mesh = buf.subarray(0, 3).toString('latin1') === 'ply' ? readPly(buf) : readObj(buf.toString('latin1'));
const nv = mesh.positions.length / 3;
for (const i of mesh.indices) if (i >= nv) die(`index ${i} out of range (${nv} vertices)`);
const facesIn = mesh.indices.length / 3;

await MeshoptSimplifier.ready;
const t0 = process.hrtime.bigint();
const target = Math.min(3 * targetFaces, mesh.indices.length);
let out, error;
if (update) {
	const indices = Uint32Array.from(mesh.indices); // the call writes its result in place
	const [count, err] = MeshoptSimplifier.simplifyWithUpdate(indices, mesh.positions, 3, new Float32Array(0), 0, [],
		null, target, 1.0, ['LockBorder']);
	out = indices.subarray(0, count);
	error = err;
} else {
	[out, error] = MeshoptSimplifier.simplify(mesh.indices, mesh.positions, 3, target, 1.0, ['LockBorder']);
}
const seconds = Number(process.hrtime.bigint() - t0) * 1e-9;

// compact: referenced vertices in their old order
const map = new Int32Array(nv).fill(-1);
for (const i of out) map[i] = 0;
const lines = [];
let next = 0;
for (let v = 0; v < nv; v++) {
	if (map[v] !== 0) continue;
	map[v] = next++;
	const p = mesh.positions;
	// a float32 printed as the shortest double that reads back to it
	lines.push(`v ${p[3 * v]} ${p[3 * v + 1]} ${p[3 * v + 2]}`);
}
for (let i = 0; i + 2 < out.length; i += 3)
	lines.push(`f ${map[out[i]] + 1} ${map[out[i + 1]] + 1} ${map[out[i + 2]] + 1}`);
writeFileSync(output + '.tmp', lines.join('\n') + '\n');
renameSync(output + '.tmp', output);

// the package's exports hide package.json: find it beside the resolved entry
const entry = createRequire(import.meta.url).resolve('meshoptimizer');
const version = JSON.parse(readFileSync(join(dirname(entry), 'package.json'), 'utf8')).version;
const peak = process.resourceUsage().maxRSS * 1024;
process.stdout.write(`${facesIn} ${out.length / 3} ${seconds.toFixed(4)} ${peak} ${error} ${version}\n`);
