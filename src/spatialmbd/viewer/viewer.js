/* spatialmbd offline animation viewer.
 *
 * Owns the data, the time, the camera and the UI.  The 3-D scene is drawn by the WebGL back end
 * (webgl.js, three.js) when the browser has WebGL 2; otherwise, or when it fails, or with the URL
 * hash #renderer=canvas, by the small Canvas-2D software renderer below: convex meshes (box,
 * cylinder, sphere) are transformed per frame, back faces culled, the remaining faces sorted
 * far-to-near (painter's algorithm) and filled with flat Lambert shading; sharp and silhouette
 * edges are outlined.  The 2-D canvas always carries the overlays (joint markers, labels, gizmo).
 * No network.  Scene data: <script type="application/json" id="spatialmbd-scene">; per-frame
 * arrays are base64 strings of little-endian Float32 values.
 */
(function () {
  'use strict';

  // ------------------------------------------------------------------------------------------
  // error reporting
  // ------------------------------------------------------------------------------------------
  var viewerErrors = [];
  window.spatialmbdViewerErrors = viewerErrors;
  function showError(msg) {
    viewerErrors.push(String(msg));
    var el = document.getElementById('hud-error');
    if (el) {
      el.textContent = 'Viewer error: ' + msg;
      el.style.display = 'block';
    }
  }
  window.addEventListener('error', function (ev) {
    showError(ev && ev.message ? ev.message : ev);
  });

  // ------------------------------------------------------------------------------------------
  // small vector / matrix helpers (3-vectors as arrays, 3x3 matrices row-major in 9-arrays)
  // ------------------------------------------------------------------------------------------
  function add(a, b) { return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]; }
  function sub(a, b) { return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]; }
  function scale(a, s) { return [a[0] * s, a[1] * s, a[2] * s]; }
  function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
  function cross(a, b) {
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  }
  function norm(a) { return Math.sqrt(dot(a, a)); }
  function normalize(a) {
    var n = norm(a);
    return n > 1e-300 ? [a[0] / n, a[1] / n, a[2] / n] : [0, 0, 0];
  }
  function matVec(A, v) {
    return [A[0] * v[0] + A[1] * v[1] + A[2] * v[2],
            A[3] * v[0] + A[4] * v[1] + A[5] * v[2],
            A[6] * v[0] + A[7] * v[1] + A[8] * v[2]];
  }
  function matMul(A, B) {
    var C = new Array(9);
    for (var i = 0; i < 3; i++) {
      for (var j = 0; j < 3; j++) {
        C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
      }
    }
    return C;
  }
  var IDENTITY = [1, 0, 0, 0, 1, 0, 0, 0, 1];

  /* Rotation matrix of Euler parameters p = [e0, e1, e2, e3] (normalised here):
   * A = (2 e0^2 - 1) I + 2 (e e^T + e0 e~), body -> global. */
  function matFromP(p) {
    var n = Math.sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2] + p[3] * p[3]);
    if (!(n > 1e-12)) { return IDENTITY.slice(); }
    var e0 = p[0] / n, e1 = p[1] / n, e2 = p[2] / n, e3 = p[3] / n;
    return [2 * (e0 * e0 + e1 * e1) - 1, 2 * (e1 * e2 - e0 * e3), 2 * (e1 * e3 + e0 * e2),
            2 * (e1 * e2 + e0 * e3), 2 * (e0 * e0 + e2 * e2) - 1, 2 * (e2 * e3 - e0 * e1),
            2 * (e1 * e3 - e0 * e2), 2 * (e2 * e3 + e0 * e1), 2 * (e0 * e0 + e3 * e3) - 1];
  }

  /* A rotation whose third column is the unit vector a (columns u, v, a). */
  function basisWithAxis(a) {
    a = normalize(a);
    var ref = Math.abs(a[0]) < 0.9 ? [1, 0, 0] : [0, 1, 0];
    var u = normalize(cross(ref, a));
    var v = cross(a, u);
    return [u[0], v[0], a[0], u[1], v[1], a[1], u[2], v[2], a[2]];
  }

  function niceStep(x) {
    if (!(x > 0) || !isFinite(x)) { return 1; }
    var e = Math.pow(10, Math.floor(Math.log(x) / Math.LN10));
    var f = x / e;
    return (f < 1.5 ? 1 : f < 3.5 ? 2 : f < 7.5 ? 5 : 10) * e;
  }

  function parseColor(hex) {
    var m = /^#([0-9a-f]{2})([0-9a-f]{2})([0-9a-f]{2})$/i.exec(hex || '');
    return m ? [parseInt(m[1], 16), parseInt(m[2], 16), parseInt(m[3], 16)] : [140, 150, 165];
  }
  function rgb(c, k, alpha) {
    var r = Math.max(0, Math.min(255, Math.round(c[0] * k)));
    var g = Math.max(0, Math.min(255, Math.round(c[1] * k)));
    var b = Math.max(0, Math.min(255, Math.round(c[2] * k)));
    return alpha === undefined ? 'rgb(' + r + ',' + g + ',' + b + ')'
      : 'rgba(' + r + ',' + g + ',' + b + ',' + alpha + ')';
  }

  // ------------------------------------------------------------------------------------------
  // meshes: convex polyhedra with outward face normals and an edge table
  // ------------------------------------------------------------------------------------------
  function boxGeometry(s) {
    var hx = s[0] / 2, hy = s[1] / 2, hz = s[2] / 2, verts = [];
    for (var i = 0; i < 8; i++) {
      verts.push([(i & 1) ? hx : -hx, (i & 2) ? hy : -hy, (i & 4) ? hz : -hz]);
    }
    var faces = [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1],
                 [4, 5, 7, 6]];
    return { verts: verts, faces: faces };
  }

  function cylinderGeometry(radius, length, n) {
    var verts = [], faces = [], h = length / 2, i;
    for (i = 0; i < n; i++) {
      var a = 2 * Math.PI * i / n;
      verts.push([radius * Math.cos(a), radius * Math.sin(a), -h]);
    }
    for (i = 0; i < n; i++) { verts.push([verts[i][0], verts[i][1], h]); }
    var bottom = [], top = [];
    for (i = 0; i < n; i++) {
      var j = (i + 1) % n;
      faces.push([i, j, n + j, n + i]);
      bottom.push(n - 1 - i);
      top.push(n + i);
    }
    faces.push(bottom, top);
    return { verts: verts, faces: faces };
  }

  function sphereGeometry(radius, nLat, nLon) {
    var verts = [[0, 0, radius]], faces = [], i, j;
    for (i = 1; i < nLat; i++) {
      var th = Math.PI * i / nLat, z = radius * Math.cos(th), rr = radius * Math.sin(th);
      for (j = 0; j < nLon; j++) {
        var ph = 2 * Math.PI * j / nLon;
        verts.push([rr * Math.cos(ph), rr * Math.sin(ph), z]);
      }
    }
    verts.push([0, 0, -radius]);
    var south = verts.length - 1;
    function ring(i, j) { return 1 + (i - 1) * nLon + ((j % nLon) + nLon) % nLon; }
    for (j = 0; j < nLon; j++) { faces.push([0, ring(1, j), ring(1, j + 1)]); }
    for (i = 1; i < nLat - 1; i++) {
      for (j = 0; j < nLon; j++) {
        faces.push([ring(i, j), ring(i + 1, j), ring(i + 1, j + 1), ring(i, j + 1)]);
      }
    }
    for (j = 0; j < nLon; j++) { faces.push([south, ring(nLat - 1, j + 1), ring(nLat - 1, j)]); }
    return { verts: verts, faces: faces };
  }

  /* Build a mesh of a shape dict in the axes of its owner (body or ground). */
  function buildMesh(shape, baseColor) {
    var geo, R = IDENTITY;
    if (shape.type === 'box') {
      geo = boxGeometry(shape.size);
      if (shape.p) { R = matFromP(shape.p); }
    } else if (shape.type === 'cylinder') {
      geo = cylinderGeometry(shape.radius, shape.length, 28);
      R = basisWithAxis(shape.axis || [0, 0, 1]);
    } else if (shape.type === 'sphere') {
      geo = sphereGeometry(shape.radius, 10, 18);
    } else if (shape.type === 'mesh') {
      // a triangle mesh: its own winding says which side is outside (it need not be convex)
      geo = { verts: [], faces: [], wound: true };
      for (var v = 0; v + 2 < shape.vertices.length; v += 3) {
        geo.verts.push([shape.vertices[v], shape.vertices[v + 1], shape.vertices[v + 2]]);
      }
      for (var f = 0; f + 2 < shape.faces.length; f += 3) {
        geo.faces.push([shape.faces[f], shape.faces[f + 1], shape.faces[f + 2]]);
      }
      if (shape.p) { R = matFromP(shape.p); }
    } else {
      return null;
    }
    var c = shape.center || [0, 0, 0];
    var verts = geo.verts.map(function (v) { return add(c, matVec(R, v)); });
    var centroid = [0, 0, 0];
    verts.forEach(function (v) { centroid = add(centroid, v); });
    centroid = scale(centroid, 1 / verts.length);
    var faces = geo.faces.map(function (idx) {
      // Newell normal, oriented away from the centroid (all our meshes are convex)
      var nrm = [0, 0, 0], fc = [0, 0, 0];
      for (var k = 0; k < idx.length; k++) {
        var a = verts[idx[k]], b = verts[idx[(k + 1) % idx.length]];
        nrm[0] += (a[1] - b[1]) * (a[2] + b[2]);
        nrm[1] += (a[2] - b[2]) * (a[0] + b[0]);
        nrm[2] += (a[0] - b[0]) * (a[1] + b[1]);
        fc = add(fc, a);
      }
      fc = scale(fc, 1 / idx.length);
      nrm = normalize(nrm);
      if (!geo.wound && dot(nrm, sub(fc, centroid)) < 0) {
        nrm = scale(nrm, -1);
        idx = idx.slice().reverse();
      }
      return { idx: idx, n: nrm, edges: [] };
    });
    // edge table: sharp edges (dihedral > ~30 deg) are always outlined, smooth ones only
    // on the silhouette
    var edges = [], map = {};
    faces.forEach(function (f, fi) {
      for (var k = 0; k < f.idx.length; k++) {
        var a = f.idx[k], b = f.idx[(k + 1) % f.idx.length];
        var key = a < b ? a + '_' + b : b + '_' + a;
        var e = map[key];
        if (e === undefined) {
          e = map[key] = edges.length;
          edges.push({ a: a, b: b, f1: fi, f2: -1, sharp: true });
        } else {
          edges[e].f2 = fi;
        }
        f.edges.push(e);
      }
    });
    edges.forEach(function (e) {
      e.sharp = e.f2 < 0 || dot(faces[e.f1].n, faces[e.f2].n) < 0.866;
    });
    var radius = 0;
    verts.forEach(function (v) { radius = Math.max(radius, norm(v)); });
    return { verts: verts, faces: faces, edges: edges, color: parseColor(shape.color || baseColor),
             radius: radius };
  }

  // ------------------------------------------------------------------------------------------
  // scene data
  // ------------------------------------------------------------------------------------------
  var raw = JSON.parse(document.getElementById('spatialmbd-scene').textContent);

  /* base64 of little-endian float32 values -> Float32Array */
  function decodeFloat32(text) {
    var bin = atob(text || ''), n = bin.length >> 2;
    var view = new DataView(new ArrayBuffer(4 * n)), out = new Float32Array(n), i;
    for (i = 0; i < 4 * n; i++) { view.setUint8(i, bin.charCodeAt(i)); }
    for (i = 0; i < n; i++) { out[i] = view.getFloat32(4 * i, true); }
    return out;
  }
  /* a body's "q" (n x 7: r then p) -> separate r (n x 3) and p (n x 4) arrays */
  function splitQ(q) {
    var n = Math.floor(q.length / 7), r = new Float32Array(3 * n), p = new Float32Array(4 * n);
    for (var k = 0; k < n; k++) {
      for (var i = 0; i < 3; i++) { r[3 * k + i] = q[7 * k + i]; }
      for (i = 0; i < 4; i++) { p[4 * k + i] = q[7 * k + 3 + i]; }
    }
    return { r: r, p: p };
  }
  if (raw.title) { document.title = raw.title; }
  var T = raw.t || [0];
  var nF = T.length;
  var tStart = T[0], tEnd = T[nF - 1], duration = tEnd - tStart;
  var UP = normalize(raw.up || [0, 0, 1]);
  if (norm(UP) === 0) { UP = [0, 0, 1]; }

  var bodies = (raw.bodies || []).map(function (b, i) {
    var meshes = (b.shapes || []).map(function (s) { return buildMesh(s, b.color); })
      .filter(function (m) { return m !== null; });
    var rp = typeof b.q === 'string' ? splitQ(decodeFloat32(b.q)) : { r: b.r, p: b.p };
    return { name: b.name || ('body' + i), color: parseColor(b.color), r: rp.r, p: rp.p,
             nSamples: Math.min(rp.r.length / 3, rp.p.length / 4), meshes: meshes,
             moving: b.moving !== false };
  });
  var groundMeshes = (raw.ground || []).map(function (s) { return buildMesh(s, '#9aa3ad'); })
    .filter(function (m) { return m !== null; });
  var joints = raw.joints || [];
  var springs = raw.springs || [];
  var arrows = (raw.arrows || []).map(function (a) {
    return { name: a.name, kind: a.kind || 'force', body: a.body, point: a.point || [0, 0, 0],
             vectors: decodeFloat32(a.vectors), scale: a.scale, color: a.color || '#d62728' };
  });
  var points = (raw.points || []).map(function (c) {
    return { name: c.name, positions: decodeFloat32(c.positions), radius: c.radius,
             color: c.color || '#e15759' };
  });

  /* index k and weight a of time t: value = (1 - a) x[k] + a x[k + 1] */
  function frameAt(t) {
    if (nF < 2 || !(t > T[0])) { return { k: 0, a: 0 }; }
    if (t >= T[nF - 1]) { return { k: nF - 1, a: 0 }; }
    var lo = 0, hi = nF - 1;
    while (hi - lo > 1) {
      var mid = (lo + hi) >> 1;
      if (T[mid] <= t) { lo = mid; } else { hi = mid; }
    }
    var dt = T[hi] - T[lo];
    return { k: lo, a: dt > 0 ? (t - T[lo]) / dt : 0 };
  }

  /* position and rotation matrix of a body at frame fr (linear r, normalised-lerp p) */
  function bodyPose(b, fr) {
    var k = Math.min(fr.k, b.nSamples - 1), a = fr.a, r = b.r, p = b.p;
    var i3 = 3 * k, i4 = 4 * k;
    var pos = [r[i3], r[i3 + 1], r[i3 + 2]];
    var q = [p[i4], p[i4 + 1], p[i4 + 2], p[i4 + 3]];
    if (a > 0 && k + 1 < b.nSamples) {
      var j3 = i3 + 3, j4 = i4 + 4;
      pos = [pos[0] + a * (r[j3] - pos[0]), pos[1] + a * (r[j3 + 1] - pos[1]),
             pos[2] + a * (r[j3 + 2] - pos[2])];
      var q1 = [p[j4], p[j4 + 1], p[j4 + 2], p[j4 + 3]];
      var s = (q[0] * q1[0] + q[1] * q1[1] + q[2] * q1[2] + q[3] * q1[3]) < 0 ? -1 : 1;
      q = [(1 - a) * q[0] + s * a * q1[0], (1 - a) * q[1] + s * a * q1[1],
           (1 - a) * q[2] + s * a * q1[2], (1 - a) * q[3] + s * a * q1[3]];
    }
    return { pos: pos, A: matFromP(q) };
  }
  var GROUND_POSE = { pos: [0, 0, 0], A: IDENTITY };

  function jointPoint(j, poses) {
    if (j.body < 0 || j.body >= poses.length) { return j.point; }
    var ps = poses[j.body];
    return add(ps.pos, matVec(ps.A, j.point));
  }

  // ------------------------------------------------------------------------------------------
  // bounding box of the whole motion (for auto-fit, grid and marker sizes)
  // ------------------------------------------------------------------------------------------
  var bbMin = [0, 0, 0], bbMax = [0, 0, 0];  // the ground frame at the origin is always shown
  var frameRadius = 0;     // the largest half-diagonal of the bodies' own box at one instant
  function grow(v) {
    for (var i = 0; i < 3; i++) {
      if (v[i] < bbMin[i]) { bbMin[i] = v[i]; }
      if (v[i] > bbMax[i]) { bbMax[i] = v[i]; }
    }
  }
  // what the camera frames: the box of the moving bodies' trajectories (with their shapes),
  // grown by the static bodies and ground shapes near it; a dummy body far away is left out
  var moving = bodies.filter(function (b) { return b.moving; });
  var mvMin = [Infinity, Infinity, Infinity], mvMax = [-Infinity, -Infinity, -Infinity];
  function growMoving(v) {
    for (var i = 0; i < 3; i++) {
      if (v[i] < mvMin[i]) { mvMin[i] = v[i]; }
      if (v[i] > mvMax[i]) { mvMax[i] = v[i]; }
    }
  }
  (function computeBounds() {
    var stride = Math.max(1, Math.floor(nF / 300));
    var ks = [];
    for (var k = 0; k < nF; k += stride) { ks.push(k); }
    if (ks[ks.length - 1] !== nF - 1) { ks.push(nF - 1); }
    ks.forEach(function (k) {
      var lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
      function own(v) {
        grow(v);
        for (var i = 0; i < 3; i++) { lo[i] = Math.min(lo[i], v[i]); hi[i] = Math.max(hi[i], v[i]); }
      }
      var poses = bodies.map(function (b) {
        var ps = bodyPose(b, { k: k, a: 0 });
        own(ps.pos);
        if (b.moving) { growMoving(ps.pos); }
        b.meshes.forEach(function (m) {
          m.verts.forEach(function (v) {
            var w = add(ps.pos, matVec(ps.A, v));
            own(w);
            if (b.moving) { growMoving(w); }
          });
        });
        return ps;
      });
      joints.forEach(function (j) { grow(jointPoint(j, poses)); });
      if (bodies.length) { frameRadius = Math.max(frameRadius, 0.5 * norm(sub(hi, lo))); }
    });
    groundMeshes.forEach(function (m) { m.verts.forEach(grow); });
    if (!moving.length || moving.length === bodies.length) { return; }
    var c = scale(add(mvMin, mvMax), 0.5), reach = 3 * Math.max(norm(sub(mvMax, mvMin)), 1e-6);
    var near = function (v) { if (norm(sub(v, c)) <= reach) { growMoving(v); } };
    near([0, 0, 0]);
    bodies.forEach(function (b) {
      if (b.moving) { return; }
      var ps = bodyPose(b, { k: 0, a: 0 });
      near(ps.pos);
      b.meshes.forEach(function (m) {
        m.verts.forEach(function (v) { near(add(ps.pos, matVec(ps.A, v))); });
      });
    });
    groundMeshes.forEach(function (m) { m.verts.forEach(near); });
  })();
  // world size used for the triad and the grid; the triad (with its letters) is then framed too
  var refSize = Math.max(0.5 * norm(sub(bbMax, bbMin)), 1e-6);
  var axLen = niceStep(0.25 * refSize);
  grow([1.15 * axLen, 1.15 * axLen, 1.15 * axLen]);
  var bbCenter = scale(add(bbMin, bbMax), 0.5);
  var sceneRadius = Math.max(0.5 * norm(sub(bbMax, bbMin)), 1e-6);
  if (!moving.length || moving.length === bodies.length) {   // frame the whole scene
    mvMin = bbMin.slice(); mvMax = bbMax.slice();
  }
  var mvCenter = scale(add(mvMin, mvMax), 0.5);
  var mvRadius = Math.max(0.5 * norm(sub(mvMax, mvMin)), 1e-6);
  // follow: the camera moves with the bodies (their mean position), for a mechanism that
  // travels several times its own size (a vehicle); on by default then
  var follow = frameRadius > 0 && sceneRadius > 4 * frameRadius;
  var followOffset = [0, 0, 0];      // the user's pan relative to the followed point

  // ------------------------------------------------------------------------------------------
  // springs, dampers, massless links, arrows and points: world-space primitives per frame
  // (segments [a, b, radius, colour], cones [base, tip, radius, colour], dots [p, radius, colour])
  // ------------------------------------------------------------------------------------------
  var wire = 0.006 * refSize, wireRadius = wire;
  function sampleAt(arr, width, fr) {
    var n = Math.floor(arr.length / width);
    if (n === 0) { return null; }
    var k = Math.min(fr.k, n - 1), a = k + 1 < n ? fr.a : 0, out = [];
    for (var i = 0; i < width; i++) {
      out.push((1 - a) * arr[width * k + i] + a * (a > 0 ? arr[width * (k + 1) + i] : 0));
    }
    return out;
  }
  function attach(body, point, poses) {
    return jointPoint({ body: body, point: point }, poses);
  }
  function helix(out, P, Q, radius, turns, color) {
    var d = sub(Q, P), L = norm(d);
    if (!(L > 0)) { return; }
    var wire = Math.min(wireRadius, 0.12 * radius);   // a thin wire on small coils
    var u = scale(d, 1 / L), B = basisWithAxis(u);
    var e1 = [B[0], B[3], B[6]], e2 = [B[1], B[4], B[7]];   // columns: normal to u
    var lead = 0.12 * L, n = Math.max(8, Math.round(16 * turns)), prev = add(P, scale(u, lead));
    out.segments.push([P, prev, wire, color]);
    var first = add(prev, scale(e1, radius));   // the coil starts one radius off the axis
    out.segments.push([prev, first, wire, color]);
    prev = first;
    for (var i = 1; i <= n; i++) {
      var s = i / n, ang = 2 * Math.PI * turns * s;
      var c = add(add(P, scale(u, lead + s * (L - 2 * lead))),
                  add(scale(e1, radius * Math.cos(ang)), scale(e2, radius * Math.sin(ang))));
      out.segments.push([prev, c, wire, color]);
      prev = c;
    }
    var end = add(Q, scale(u, -lead));
    out.segments.push([prev, end, wire, color], [end, Q, wire, color]);
  }
  function damper(out, P, Q, radius, color) {
    var d = sub(Q, P), L = norm(d);
    if (!(L > 0)) { return; }
    var u = scale(d, 1 / L);
    out.segments.push([P, add(P, scale(u, 0.55 * L)), 0.55 * radius, color]);   // cylinder
    out.segments.push([add(P, scale(u, 0.3 * L)), Q, 0.22 * radius, '#5b6472']); // piston rod
  }
  function arrow(out, O, V, color) {
    var L = norm(V);
    if (!(L > 0)) { return; }
    var head = Math.min(0.35 * L, 0.08 * refSize), tipBase = add(O, scale(V, 1 - head / L));
    out.segments.push([O, tipBase, 1.6 * wire, color]);
    out.cones.push([tipBase, add(O, V), 0.35 * head, color]);
  }
  var arrowScales = arrows.map(function (a) {
    if (typeof a.scale === 'number' && a.scale > 0) { return a.scale; }
    var big = 0;
    for (var i = 0; i + 2 < a.vectors.length; i += 3) {
      big = Math.max(big, Math.hypot(a.vectors[i], a.vectors[i + 1], a.vectors[i + 2]));
    }
    return big > 0 ? 0.3 * refSize / big : 1;   // the largest arrow: 30 % of the scene size
  });
  function extrasAt(fr, poses) {
    var out = { segments: [], cones: [], dots: [] };
    springs.forEach(function (sp) {
      var P = attach(sp.body_i, sp.point_i || [0, 0, 0], poses);
      var Q = attach(sp.body_j, sp.point_j || [0, 0, 0], poses);
      // default coil radius: slender (a tenth of the length), never wider than the scene allows
      var R = sp.radius > 0 ? sp.radius : Math.min(0.035 * refSize, 0.08 * norm(sub(Q, P)));
      var col = sp.color || '#6b7280';
      var kind = sp.kind || 'spring';
      if (kind === 'link') {
        out.segments.push([P, Q, 2 * wire, col]);
        out.dots.push([P, 3.5 * wire, col], [Q, 3.5 * wire, col]);
      } else {
        if (kind === 'spring' || kind === 'spring_damper') { helix(out, P, Q, R, sp.turns > 0 ? sp.turns : 8, col); }
        if (kind === 'damper' || kind === 'spring_damper') { damper(out, P, Q, kind === 'damper' ? R : 0.6 * R, col); }
      }
    });
    arrows.forEach(function (a, i) {
      var V = sampleAt(a.vectors, 3, fr);
      if (!V) { return; }
      arrow(out, attach(a.body, a.point, poses), scale(V, arrowScales[i]), a.color);
    });
    points.forEach(function (c) {
      var P = sampleAt(c.positions, 3, fr);
      if (P) { out.dots.push([P, c.radius > 0 ? c.radius : 0.015 * refSize, c.color]); }
    });
    return out;
  }

  // ------------------------------------------------------------------------------------------
  // camera: turntable orbit about `target` with `up` = -gravity
  // ------------------------------------------------------------------------------------------
  var FOVY = 35 * Math.PI / 180;
  // horizontal reference axis: the global axis least aligned with up (x preferred)
  var RIGHT0 = (function () {
    var axes = [[1, 0, 0], [0, 1, 0], [0, 0, 1]], best = null, bestDot = 2;
    axes.forEach(function (e) {
      var d = Math.abs(dot(e, UP));
      if (d < bestDot - 1e-9) { bestDot = d; best = e; }
    });
    return normalize(sub(best, scale(UP, dot(best, UP))));
  })();
  var BACK0 = cross(RIGHT0, UP);  // from the target toward the default camera
  var cam = { target: bbCenter.slice(), dist: 1, yaw: 30 * Math.PI / 180,
              pitch: 20 * Math.PI / 180 };

  var canvas = document.getElementById('canvas');
  var ctx = canvas.getContext('2d');
  var viewW = 1, viewH = 1, dpr = 1;

  function cameraFrame() {
    var cp = Math.cos(cam.pitch), sp = Math.sin(cam.pitch);
    var dir = add(scale(add(scale(BACK0, Math.cos(cam.yaw)), scale(RIGHT0, Math.sin(cam.yaw))),
                        cp), scale(UP, sp));
    var C = add(cam.target, scale(dir, cam.dist));
    var f = scale(dir, -1);
    var r = normalize(cross(f, UP));
    var u = cross(r, f);
    var focal = 0.5 * viewH / Math.tan(FOVY / 2);
    return { C: C, f: f, r: r, u: u, focal: focal, cx: 0.5 * viewW, cy: 0.5 * viewH,
             near: Math.max(cam.dist * 1e-3, 1e-9) };
  }
  function toCam(fr, P) {
    var d = sub(P, fr.C);
    return [dot(d, fr.r), dot(d, fr.u), dot(d, fr.f)];
  }
  function project(fr, c) {
    return [fr.cx + c[0] / c[2] * fr.focal, fr.cy - c[1] / c[2] * fr.focal];
  }
  /* a world segment clipped to the near plane: [screenA, screenB, mean depth] or null */
  function projectSegment(fr, P, Q) {
    var a = toCam(fr, P), b = toCam(fr, Q), n = fr.near;
    if (a[2] < n && b[2] < n) { return null; }
    var s;
    if (a[2] < n) { s = (n - a[2]) / (b[2] - a[2]); a = add(a, scale(sub(b, a), s)); }
    if (b[2] < n) { s = (n - b[2]) / (a[2] - b[2]); b = add(b, scale(sub(a, b), s)); }
    return [project(fr, a), project(fr, b), 0.5 * (a[2] + b[2])];
  }

  /* Frame the bounding box of the whole motion for the current viewing direction: the
   * smallest distance at which all 8 corners project inside the view (with a margin). */
  function bodiesCentre(poses) {
    var c = [0, 0, 0], n = 0;
    poses.forEach(function (ps, i) {
      if (bodies[i].moving || !moving.length) { c = add(c, ps.pos); n += 1; }
    });
    return n ? scale(c, 1 / n) : bbCenter.slice();
  }
  function followedTarget() {
    var frm = frameAt(curTime);
    return add(bodiesCentre(bodies.map(function (b) { return bodyPose(b, frm); })),
               followOffset);
  }
  function fit() {
    if (follow) {
      // the bodies at this instant, whatever their size, a third of the view across
      followOffset = [0, 0, 0];
      cam.target = followedTarget();
      cam.dist = 3.0 * Math.max(frameRadius, 1e-6) / Math.tan(FOVY / 2);
      requestRender();
      return;
    }
    cam.target = mvCenter.slice();
    cam.dist = 1;
    var fr = cameraFrame();
    var tanY = Math.tan(FOVY / 2), tanX = tanY * viewW / Math.max(viewH, 1);
    var dist = 0;
    for (var i = 0; i < 8; i++) {
      var c = [(i & 1) ? mvMax[0] : mvMin[0], (i & 2) ? mvMax[1] : mvMin[1],
               (i & 4) ? mvMax[2] : mvMin[2]];
      var d = sub(c, mvCenter);
      var x = dot(d, fr.r), y = dot(d, fr.u), z = dot(d, fr.f);
      dist = Math.max(dist, Math.abs(x) / tanX - z, Math.abs(y) / tanY - z, mvRadius * 0.2);
    }
    cam.dist = 1.15 * dist;
    requestRender();
  }

  // ------------------------------------------------------------------------------------------
  // rendering
  // ------------------------------------------------------------------------------------------
  function addMesh(prims, m, pose, fr, L) {
    var nv = m.verts.length, w = new Array(nv), sc = new Array(nv), cz = new Array(nv), i;
    for (i = 0; i < nv; i++) {
      var wv = add(pose.pos, matVec(pose.A, m.verts[i]));
      var c = toCam(fr, wv);
      w[i] = wv;
      cz[i] = c[2];
      sc[i] = c[2] > fr.near ? project(fr, c) : null;
    }
    var nf = m.faces.length, front = new Array(nf), nws = new Array(nf);
    for (i = 0; i < nf; i++) {
      var face = m.faces[i];
      nws[i] = matVec(pose.A, face.n);
      front[i] = dot(nws[i], sub(fr.C, w[face.idx[0]])) > 0;
    }
    for (i = 0; i < nf; i++) {
      if (!front[i]) { continue; }
      var f = m.faces[i], pts = [], depth = 0, ok = true;
      for (var k = 0; k < f.idx.length; k++) {
        var s = sc[f.idx[k]];
        if (!s) { ok = false; break; }
        pts.push(s);
        depth += cz[f.idx[k]];
      }
      if (!ok) { continue; }
      var n = nws[i];
      var lambert = Math.max(0, dot(n, L));
      var sky = 0.5 + 0.5 * dot(n, UP);
      var k2 = 0.46 + 0.5 * lambert + 0.14 * sky;
      var segs = [];
      for (var e = 0; e < f.edges.length; e++) {
        var ed = m.edges[f.edges[e]];
        if (ed.sharp || front[ed.f1] !== front[ed.f2]) {
          var pa = sc[ed.a], pb = sc[ed.b];
          if (pa && pb) { segs.push(pa, pb); }
        }
      }
      prims.push({ kind: 0, depth: depth / f.idx.length, pts: pts, fill: rgb(m.color, k2),
                   outline: rgb(m.color, 0.32), segs: segs });
    }
  }

  function addLine(prims, fr, P, Q, color, width, pieces) {
    for (var i = 0; i < pieces; i++) {
      var a = add(P, scale(sub(Q, P), i / pieces)), b = add(P, scale(sub(Q, P), (i + 1) / pieces));
      var seg = projectSegment(fr, a, b);
      if (seg) {
        prims.push({ kind: 1, depth: seg[2], a: seg[0], b: seg[1], color: color, width: width });
      }
    }
  }

  var grid = (function () {
    var step = niceStep(2 * refSize / 10);
    // below everything: the lowest corner of the bounding box along up (origin included)
    var level = 0, corners = [];
    for (var i = 0; i < 8; i++) {
      corners.push([(i & 1) ? bbMax[0] : bbMin[0], (i & 2) ? bbMax[1] : bbMin[1],
                    (i & 4) ? bbMax[2] : bbMin[2]]);
    }
    corners.forEach(function (c) { level = Math.min(level, dot(c, UP)); });
    var e1 = RIGHT0, e2 = cross(UP, RIGHT0);
    var c1 = Math.round(dot(bbCenter, e1) / step) * step;
    var c2 = Math.round(dot(bbCenter, e2) / step) * step;
    var nHalf = Math.max(3, Math.ceil(1.4 * refSize / step));
    return { step: step, level: level, e1: e1, e2: e2, c1: c1, c2: c2, nHalf: nHalf };
  })();

  function drawGrid(fr, alpha) {
    var g = grid, h = g.nHalf * g.step, i;
    var base = scale(UP, g.level);
    function P(a, b) { return add(base, add(scale(g.e1, a), scale(g.e2, b))); }
    ctx.lineCap = 'butt';
    for (i = -g.nHalf; i <= g.nHalf; i++) {
      var a = g.c1 + i * g.step, b = g.c2 + i * g.step;
      var major1 = Math.abs(a) < 1e-9 * g.step, major2 = Math.abs(b) < 1e-9 * g.step;
      var lines = [[P(a, g.c2 - h), P(a, g.c2 + h), major1],
                   [P(g.c1 - h, b), P(g.c1 + h, b), major2]];
      lines.forEach(function (ln) {
        var seg = projectSegment(fr, ln[0], ln[1]);
        if (!seg) { return; }
        ctx.strokeStyle = ln[2] ? 'rgba(60,70,90,' + (0.55 * alpha) + ')'
          : 'rgba(80,92,112,' + (0.28 * alpha) + ')';
        ctx.lineWidth = ln[2] ? 1.3 : 1;
        ctx.beginPath();
        ctx.moveTo(seg[0][0], seg[0][1]);
        ctx.lineTo(seg[1][0], seg[1][1]);
        ctx.stroke();
      });
    }
  }

  /* soft shadows of the bodies on the grid plane (straight down along -up) */
  function drawShadows(fr, poses) {
    ctx.beginPath();
    var any = false;
    bodies.forEach(function (b, bi) {
      var pose = poses[bi];
      b.meshes.forEach(function (m) {
        var pts = m.verts.map(function (v) {
          var w = add(pose.pos, matVec(pose.A, v));
          var c = toCam(fr, sub(w, scale(UP, dot(w, UP) - grid.level)));
          return c[2] > fr.near ? project(fr, c) : null;
        });
        m.faces.forEach(function (f) {
          if (dot(matVec(pose.A, f.n), UP) <= 0) { return; }
          for (var k = 0; k < f.idx.length; k++) { if (!pts[f.idx[k]]) { return; } }
          ctx.moveTo(pts[f.idx[0]][0], pts[f.idx[0]][1]);
          for (k = 1; k < f.idx.length; k++) { ctx.lineTo(pts[f.idx[k]][0], pts[f.idx[k]][1]); }
          ctx.closePath();
          any = true;
        });
      });
    });
    if (any) {
      ctx.fillStyle = 'rgba(30,40,60,0.16)';
      ctx.fill('nonzero');
    }
  }

  function drawBackground() {
    var g = ctx.createLinearGradient(0, 0, 0, viewH);
    g.addColorStop(0, '#f7f9fc');
    g.addColorStop(1, '#cfd6df');
    ctx.fillStyle = g;
    ctx.fillRect(0, 0, viewW, viewH);
  }

  function drawPrims(prims) {
    prims.sort(function (a, b) { return b.depth - a.depth; });
    ctx.lineJoin = 'round';
    ctx.lineCap = 'round';
    for (var i = 0; i < prims.length; i++) {
      var q = prims[i], k;
      if (q.kind === 0) {
        ctx.beginPath();
        ctx.moveTo(q.pts[0][0], q.pts[0][1]);
        for (k = 1; k < q.pts.length; k++) { ctx.lineTo(q.pts[k][0], q.pts[k][1]); }
        ctx.closePath();
        ctx.fillStyle = q.fill;
        ctx.fill();
        ctx.strokeStyle = q.fill;  // hides anti-aliasing seams between neighbouring faces
        ctx.lineWidth = 0.8;
        ctx.stroke();
        if (q.segs.length) {
          ctx.beginPath();
          for (k = 0; k < q.segs.length; k += 2) {
            ctx.moveTo(q.segs[k][0], q.segs[k][1]);
            ctx.lineTo(q.segs[k + 1][0], q.segs[k + 1][1]);
          }
          ctx.strokeStyle = q.outline;
          ctx.lineWidth = 1.3;
          ctx.stroke();
        }
      } else if (q.kind === 2) {
        ctx.beginPath();
        ctx.arc(q.at[0], q.at[1], q.radius, 0, 2 * Math.PI);
        ctx.fillStyle = q.color;
        ctx.fill();
      } else {
        ctx.beginPath();
        ctx.moveTo(q.a[0], q.a[1]);
        ctx.lineTo(q.b[0], q.b[1]);
        ctx.strokeStyle = q.color;
        ctx.lineWidth = q.width;
        ctx.stroke();
      }
    }
  }

  function label(text, x, y, color) {
    ctx.font = '600 12px system-ui, "DejaVu Sans", Arial, sans-serif';
    ctx.lineWidth = 3;
    ctx.strokeStyle = 'rgba(255,255,255,0.85)';
    ctx.strokeText(text, x, y);
    ctx.fillStyle = color;
    ctx.fillText(text, x, y);
  }

  var AXES = [[[1, 0, 0], '#d62728', 'x'], [[0, 1, 0], '#2ca02c', 'y'], [[0, 0, 1], '#1f5fd6', 'z']];

  function drawGizmo(fr) {
    var ox = 46, oy = viewH - 46, len = 30;
    var items = AXES.map(function (ax) {
      return { d: [dot(ax[0], fr.r), -dot(ax[0], fr.u)], z: dot(ax[0], fr.f), ax: ax };
    });
    items.sort(function (a, b) { return b.z - a.z; });
    ctx.beginPath();
    ctx.arc(ox, oy, len + 10, 0, 2 * Math.PI);
    ctx.fillStyle = 'rgba(255,255,255,0.55)';
    ctx.fill();
    ctx.lineCap = 'round';
    items.forEach(function (it) {
      ctx.beginPath();
      ctx.moveTo(ox, oy);
      ctx.lineTo(ox + it.d[0] * len, oy + it.d[1] * len);
      ctx.strokeStyle = it.ax[1];
      ctx.lineWidth = 2.5;
      ctx.stroke();
      ctx.textAlign = 'center';
      ctx.textBaseline = 'middle';
      label(it.ax[2], ox + it.d[0] * (len + 8), oy + it.d[1] * (len + 8), it.ax[1]);
    });
    ctx.textAlign = 'left';
    ctx.textBaseline = 'alphabetic';
  }

  var curTime = tStart, playing = false, speed = 1, lastTs = null, rafId = 0;
  var showLabels = false;

  /* screen size in px of a world length s at point P */
  function pixels(fr, P, s) {
    var z = toCam(fr, P)[2];
    return z > fr.near ? s * fr.focal / z : 0;
  }

  function render() {
    if (follow) { cam.target = followedTarget(); }
    var fr = cameraFrame();
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    var frm = frameAt(curTime);
    var poses = bodies.map(function (b) { return bodyPose(b, frm); });
    if (glView) {
      ctx.clearRect(0, 0, viewW, viewH);
      try {
        glView.render({ C: fr.C, f: fr.f, fovy: FOVY, near: fr.near,
                        far: cam.dist + 20 * sceneRadius, width: viewW, height: viewH, dpr: dpr },
                      poses, extrasAt(frm, poses));
      } catch (e) {
        fallBack(e);
        render();
        return;
      }
      drawOverlays(fr, poses);
      return;
    }
    drawBackground();
    // key light from the upper left of the viewer, in world axes
    var L = normalize(add(add(scale(fr.r, -0.45), scale(fr.u, 0.65)), scale(fr.f, -0.62)));
    var camAbove = dot(fr.C, UP) >= grid.level;
    if (camAbove) {
      drawGrid(fr, 1);
      drawShadows(fr, poses);
    }
    var prims = [];
    groundMeshes.forEach(function (m) { addMesh(prims, m, GROUND_POSE, fr, L); });
    bodies.forEach(function (b, i) {
      b.meshes.forEach(function (m) { addMesh(prims, m, poses[i], fr, L); });
    });
    AXES.forEach(function (ax) {
      addLine(prims, fr, [0, 0, 0], scale(ax[0], axLen), ax[1], 3, 8);
    });
    var extras = extrasAt(frm, poses);
    extras.segments.forEach(function (s) {
      addLine(prims, fr, s[0], s[1], s[3], Math.max(1.5, Math.min(8, pixels(fr, s[0], 2 * s[2]))), 1);
    });
    extras.cones.forEach(function (c) { addLine(prims, fr, c[0], c[1], c[3], 6, 2); });
    extras.dots.forEach(function (d) {
      var c = toCam(fr, d[0]);
      if (c[2] > fr.near) {
        prims.push({ kind: 2, depth: c[2], at: project(fr, c), color: d[2],
                     radius: Math.max(2, pixels(fr, d[0], d[1])) });
      }
    });
    drawPrims(prims);
    if (!camAbove) { drawGrid(fr, 0.6); }
    drawOverlays(fr, poses);
  }

  /* axis letters, joint markers, labels and the gizmo: 2-D, on top of either back end */
  function drawOverlays(fr, poses) {
    // axis letters of the ground frame
    ctx.textAlign = 'center';
    ctx.textBaseline = 'middle';
    AXES.forEach(function (ax) {
      var c = toCam(fr, scale(ax[0], axLen * 1.12));
      if (c[2] > fr.near) {
        var s = project(fr, c);
        label(ax[2], s[0], s[1], ax[1]);
      }
    });
    // joint markers (drawn on top so hidden joints stay visible); smaller when there are many,
    // so that hundreds of joints do not hide the bodies
    var mr = joints.length <= 50 ? 4.5 : Math.max(1.5, 4.5 * Math.sqrt(50 / joints.length));
    joints.forEach(function (j) {
      var c = toCam(fr, jointPoint(j, poses));
      if (!(c[2] > fr.near)) { return; }
      var s = project(fr, c);
      ctx.beginPath();
      if (j.body < 0) {
        ctx.rect(s[0] - mr, s[1] - mr, 2 * mr, 2 * mr);
      } else {
        ctx.arc(s[0], s[1], mr, 0, 2 * Math.PI);
      }
      ctx.fillStyle = '#ffc21a';
      ctx.fill();
      ctx.lineWidth = mr > 3 ? 1.5 : 0.75;
      ctx.strokeStyle = '#4a3600';
      ctx.stroke();
      if (showLabels) {
        ctx.textAlign = 'left';
        label(j.name + (j.type ? ' (' + j.type + ')' : ''), s[0] + 8, s[1] - 8, '#4a3600');
      }
    });
    if (showLabels) {
      ctx.textAlign = 'center';
      bodies.forEach(function (b, i) {
        var c = toCam(fr, poses[i].pos);
        if (c[2] > fr.near) {
          var s = project(fr, c);
          label(b.name, s[0], s[1], rgb(b.color, 0.45));
        }
      });
    }
    ctx.textAlign = 'left';
    ctx.textBaseline = 'alphabetic';
    drawGizmo(fr);
  }

  // ------------------------------------------------------------------------------------------
  // back end: WebGL (webgl.js) unless unavailable, failing, or #renderer=canvas
  // ------------------------------------------------------------------------------------------
  var glView = null, rendererName = 'canvas', fallbackReason = '';
  function fallBack(err) {
    fallbackReason = String(err && err.message ? err.message : err);
    if (glView && glView.canvas && glView.canvas.parentNode) {
      glView.canvas.parentNode.removeChild(glView.canvas);
    }
    glView = null;
    rendererName = 'canvas';
    if (window.console) { console.warn('spatialmbd viewer: WebGL renderer unavailable (' + fallbackReason + '); using the Canvas renderer'); }
  }
  (function chooseRenderer() {
    var forced = /(^|[#&;])renderer=canvas(\b|$)/.test(window.location.hash || '');
    if (forced) { fallbackReason = 'renderer=canvas requested'; return; }
    if (typeof window.spatialmbdWebGL !== 'function') { fallBack('WebGL back end not included'); return; }
    try {
      glView = window.spatialmbdWebGL({
        host: document.getElementById('view'), before: canvas, up: UP, axLen: axLen,
        axes: AXES, grid: grid,
        bodies: (raw.bodies || []).map(function (b) { return { shapes: b.shapes, color: b.color }; }),
        ground: raw.ground || []
      });
      rendererName = 'webgl';
      // a GPU reset or driver failure later on: continue with the Canvas renderer
      glView.canvas.addEventListener('webglcontextlost', function (ev) {
        ev.preventDefault();
        fallBack('the WebGL context was lost');
        requestRender();
      });
    } catch (e) {
      fallBack(e);
    }
  })();

  // ------------------------------------------------------------------------------------------
  // UI
  // ------------------------------------------------------------------------------------------
  var btnPlay = document.getElementById('btn-play');
  var slider = document.getElementById('slider');
  var timeLabel = document.getElementById('time-label');
  var speedSel = document.getElementById('speed');
  var btnFit = document.getElementById('btn-fit');
  var chkLabels = document.getElementById('chk-labels');
  var chkFollow = document.getElementById('chk-follow');
  chkFollow.checked = follow;
  function setFollow(on) {
    follow = !!on;
    chkFollow.checked = follow;
    fit();
  }
  var digits = duration > 0 && duration < 10 ? 3 : 2;

  slider.min = String(tStart);
  slider.max = String(duration > 0 ? tEnd : tStart + 1);
  slider.disabled = !(duration > 0);
  btnPlay.disabled = !(duration > 0);

  function updateUI() {
    slider.value = String(curTime);
    timeLabel.textContent = 't = ' + curTime.toFixed(digits) + ' s / ' + tEnd.toFixed(digits) + ' s';
    btnPlay.textContent = playing ? 'Pause' : 'Play';
  }

  function resize() {
    dpr = window.devicePixelRatio || 1;
    var w = Math.max(1, canvas.clientWidth), h = Math.max(1, canvas.clientHeight);
    if (w !== viewW || h !== viewH || canvas.width !== Math.round(w * dpr)) {
      viewW = w;
      viewH = h;
      canvas.width = Math.round(w * dpr);
      canvas.height = Math.round(h * dpr);
    }
  }

  function frame(ts) {
    rafId = 0;
    if (playing) {
      if (lastTs !== null) {
        var dt = Math.min(0.25, Math.max(0, (ts - lastTs) / 1000));
        curTime += dt * speed;
        if (curTime > tEnd) { curTime = duration > 0 ? tStart + (curTime - tStart) % duration : tStart; }
      }
      lastTs = ts;
    }
    draw();
    if (playing) { rafId = window.requestAnimationFrame(frame); }
  }
  function draw() {
    resize();
    render();
    updateUI();
  }
  function requestRender() {
    if (!rafId) { rafId = window.requestAnimationFrame(frame); }
  }

  function clampTime(t) {
    t = Number(t);
    if (!isFinite(t)) { return curTime; }
    return Math.min(tEnd, Math.max(tStart, t));
  }
  function play() {
    if (!(duration > 0) || playing) { return; }
    if (curTime >= tEnd) { curTime = tStart; }
    playing = true;
    lastTs = null;
    requestRender();
  }
  function pause() {
    playing = false;
    lastTs = null;
    draw();
  }
  /* show time t (clamped to the recorded range), paused; draws synchronously */
  function setTime(t) {
    playing = false;
    lastTs = null;
    curTime = clampTime(t);
    draw();
  }
  function setSpeed(s) {
    s = Number(s);
    if (isFinite(s) && s > 0) {
      speed = s;
      var best = null;
      Array.prototype.forEach.call(speedSel.options, function (o) {
        if (Math.abs(Number(o.value) - s) < 1e-9) { best = o.value; }
      });
      if (best !== null) { speedSel.value = best; }
    }
  }

  btnPlay.addEventListener('click', function () { if (playing) { pause(); } else { play(); } });
  slider.addEventListener('input', function () { setTime(slider.value); });
  speedSel.addEventListener('change', function () { setSpeed(speedSel.value); });
  btnFit.addEventListener('click', function () { fit(); });
  chkLabels.addEventListener('change', function () { showLabels = chkLabels.checked; requestRender(); });
  chkFollow.addEventListener('change', function () { setFollow(chkFollow.checked); });
  window.addEventListener('resize', function () { requestRender(); });

  document.addEventListener('keydown', function (ev) {
    var tag = ev.target && ev.target.tagName;
    if (tag === 'INPUT' || tag === 'SELECT' || tag === 'BUTTON' || tag === 'TEXTAREA') { return; }
    if (ev.key === ' ' || ev.key === 'Spacebar') {
      ev.preventDefault();
      if (playing) { pause(); } else { play(); }
    } else if (ev.key === 'f' || ev.key === 'F') {
      fit();
    }
  });

  // mouse: drag = orbit, shift-drag / right-drag / middle-drag = pan, wheel = zoom
  var drag = null;
  canvas.addEventListener('contextmenu', function (ev) { ev.preventDefault(); });
  canvas.addEventListener('pointerdown', function (ev) {
    drag = { x: ev.clientX, y: ev.clientY, pan: ev.shiftKey || ev.button === 2 || ev.button === 1,
             id: ev.pointerId };
    try { canvas.setPointerCapture(ev.pointerId); } catch (e) { /* not capturable */ }
    canvas.classList.add('dragging');
    ev.preventDefault();
  });
  canvas.addEventListener('pointermove', function (ev) {
    if (!drag || ev.pointerId !== drag.id) { return; }
    var dx = ev.clientX - drag.x, dy = ev.clientY - drag.y;
    drag.x = ev.clientX;
    drag.y = ev.clientY;
    if (drag.pan) {
      var fr = cameraFrame();
      var s = 2 * cam.dist * Math.tan(FOVY / 2) / Math.max(viewH, 1);
      var shift = add(scale(fr.r, -dx * s), scale(fr.u, dy * s));
      if (follow) { followOffset = add(followOffset, shift); }
      cam.target = add(cam.target, shift);
    } else {
      cam.yaw -= dx * 0.008;
      cam.pitch = Math.max(-1.55, Math.min(1.55, cam.pitch + dy * 0.008));
    }
    requestRender();
  });
  function endDrag(ev) {
    if (drag && ev.pointerId === drag.id) {
      drag = null;
      canvas.classList.remove('dragging');
    }
  }
  canvas.addEventListener('pointerup', endDrag);
  canvas.addEventListener('pointercancel', endDrag);
  canvas.addEventListener('wheel', function (ev) {
    ev.preventDefault();
    var d = ev.deltaY * (ev.deltaMode === 1 ? 16 : ev.deltaMode === 2 ? 400 : 1);
    cam.dist = Math.min(1e6 * sceneRadius, Math.max(1e-4 * sceneRadius,
                                                    cam.dist * Math.exp(d * 0.0015)));
    requestRender();
  }, { passive: false });

  /* URL hash: #t=1.25 (show that time, paused), speed=2, play=1 */
  function applyHash() {
    var h = (window.location.hash || '').replace(/^#/, ''), params = {};
    h.split(/[&;]/).forEach(function (kv) {
      var i = kv.indexOf('=');
      if (i > 0) { params[decodeURIComponent(kv.slice(0, i))] = decodeURIComponent(kv.slice(i + 1)); }
    });
    if (params.speed !== undefined) { setSpeed(params.speed); }
    if (params.follow !== undefined) { setFollow(params.follow === '1'); }
    if (params.t !== undefined) {
      setTime(params.t);
      return true;
    }
    if (params.play === '1') { play(); return true; }
    if (params.play === '0') { pause(); return true; }
    return false;
  }
  window.addEventListener('hashchange', applyHash);

  // ------------------------------------------------------------------------------------------
  // start
  // ------------------------------------------------------------------------------------------
  resize();
  fit();
  draw();
  window.spatialmbdViewer = {
    setTime: setTime,
    getTime: function () { return curTime; },
    nFrames: nF,
    tStart: tStart,
    tEnd: tEnd,
    play: play,
    pause: pause,
    isPlaying: function () { return playing; },
    setSpeed: setSpeed,
    getSpeed: function () { return speed; },
    fit: fit,
    /* follow the bodies with the camera (on by default when they travel several times their
     * own size), and where the camera looks */
    setFollow: function (on) { setFollow(on); draw(); },
    isFollowing: function () { return follow; },
    cameraTarget: function () { return cam.target.slice(); },
    /* orbit angles in degrees (yaw about up, pitch above the horizon), then fit */
    setView: function (yawDeg, pitchDeg) {
      cam.yaw = Number(yawDeg) * Math.PI / 180;
      cam.pitch = Math.max(-1.55, Math.min(1.55, Number(pitchDeg) * Math.PI / 180));
      fit();
      draw();
    },
    errors: viewerErrors,
    /* 'webgl' or 'canvas', and why the Canvas renderer is used */
    renderer: function () { return rendererName; },
    fallbackReason: function () { return fallbackReason; },
    drawCalls: function () { return glView ? glView.drawCalls() : null; },
    /* CSS-pixel position [x, y] of a point (body axes, m) of body i (-1: global) now, or null */
    screenPosition: function (i, pointLocal) {
      var fr = cameraFrame(), frm = frameAt(curTime);
      var poses = bodies.map(function (b) { return bodyPose(b, frm); });
      var c = toCam(fr, jointPoint({ body: i, point: pointLocal || [0, 0, 0] }, poses));
      return c[2] > fr.near ? project(fr, c) : null;
    },
    ready: true
  };
  if (!applyHash()) { play(); }
})();
