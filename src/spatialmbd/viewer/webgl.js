/* spatialmbd viewer: the WebGL back end (three.js, bundled as three.min.js in the same page).
 *
 * viewer.js owns the data, the time, the camera and the UI; it asks this back end to draw the
 * 3-D scene into a WebGL canvas placed under its own 2-D canvas (which then only carries the
 * overlays: joint markers, labels, axis letters, the orientation gizmo).  Shapes are drawn with
 * one THREE.InstancedMesh per primitive type (box, cylinder, sphere): a repeated shape costs one
 * instance, not one draw call.  Line-like items (spring helices, dampers, massless links, force
 * arrows) are instances of a unit cylinder / cone; contact points are instanced spheres.
 *
 * window.spatialmbdWebGL(options) throws when WebGL 2 or the bundle is missing; viewer.js then
 * falls back to its Canvas-2D renderer, so the page never comes up blank.
 */
(function () {
  'use strict';

  function webgl2Available() {
    try {
      var probe = document.createElement('canvas');
      var gl = probe.getContext('webgl2');
      if (!gl) { return false; }
      var lose = gl.getExtension('WEBGL_lose_context');
      if (lose) { lose.loseContext(); }
      return true;
    } catch (e) {
      return false;
    }
  }

  /* options: host (element), before (element the GL canvas goes under), bodies (each with
   * shapes and colour), ground (shapes), grid {step, level, e1, e2, c1, c2, nHalf}, axLen,
   * axes [[dir, colour, letter]], up */
  window.spatialmbdWebGL = function (options) {
    if (typeof THREE === 'undefined') { throw new Error('the three.js bundle is missing'); }
    if (!webgl2Available()) { throw new Error('WebGL 2 is not available in this browser'); }

    var canvas = document.createElement('canvas');
    canvas.id = 'gl-canvas';
    canvas.setAttribute('aria-hidden', 'true');
    canvas.style.cssText = 'position:absolute;left:0;top:0;width:100%;height:100%;' +
      'display:block;pointer-events:none;';
    options.host.insertBefore(canvas, options.before);
    var renderer;
    try {
      renderer = new THREE.WebGLRenderer({ canvas: canvas, antialias: true, alpha: true,
                                           preserveDrawingBuffer: true });
    } catch (e) {
      canvas.parentNode.removeChild(canvas);
      throw e;
    }
    renderer.setClearColor(0x000000, 0);  // the page's gradient shows through

    var UP = new THREE.Vector3().fromArray(options.up);
    var scene = new THREE.Scene();
    var camera = new THREE.PerspectiveCamera(35, 1, 0.01, 100);
    camera.up.copy(UP);
    scene.add(camera);
    var hemi = new THREE.HemisphereLight(0xffffff, 0x8d96a3, 1.6);
    hemi.position.copy(UP);
    scene.add(hemi);
    // key light fixed to the camera: from the upper left of the viewer (as the Canvas renderer)
    var key = new THREE.DirectionalLight(0xffffff, 1.9);
    key.position.set(-0.45, 0.65, 0.62);
    camera.add(key);
    camera.add(key.target);

    // ---------------------------------------------------------------------------- shapes
    var geometries = {
      box: new THREE.BoxGeometry(1, 1, 1),
      cylinder: new THREE.CylinderGeometry(1, 1, 1, 32, 1, false),   // axis along y
      sphere: new THREE.SphereGeometry(1, 32, 16),
      rod: new THREE.CylinderGeometry(1, 1, 1, 10, 1, false),
      cone: new THREE.ConeGeometry(1, 1, 16, 1, false),
      dot: new THREE.SphereGeometry(1, 14, 8)
    };
    var Y = new THREE.Vector3(0, 1, 0);
    var tmpQ = new THREE.Quaternion(), tmpV = new THREE.Vector3(), tmpS = new THREE.Vector3();

    /* local matrix of a shape in its body (or global) axes; the unit geometry is scaled first */
    function shapeMatrix(s) {
      var pos = new THREE.Vector3().fromArray(s.center || [0, 0, 0]);
      var q = new THREE.Quaternion(), scale = new THREE.Vector3(1, 1, 1);
      if (s.type === 'box') {
        scale.fromArray(s.size);
        // Euler parameters [e0, e1, e2, e3] -> three's (x, y, z, w)
        if (s.p) { q.set(s.p[1], s.p[2], s.p[3], s.p[0]).normalize(); }
      } else if (s.type === 'cylinder') {
        scale.set(s.radius, s.length, s.radius);
        q.setFromUnitVectors(Y, new THREE.Vector3().fromArray(s.axis || [0, 0, 1]).normalize());
      } else if (s.type === 'sphere') {
        scale.set(s.radius, s.radius, s.radius);
      } else {
        return null;
      }
      return new THREE.Matrix4().compose(pos, q, scale);
    }

    // triangle meshes: one THREE.Mesh each (their own geometry), placed like the instances
    var meshShapes = [];
    function addTriangleMesh(s, body, color) {
      var geometry = new THREE.BufferGeometry();
      geometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(s.vertices), 3));
      geometry.setIndex(s.faces);
      geometry.computeVertexNormals();
      var mesh = new THREE.Mesh(geometry, new THREE.MeshStandardMaterial(
        { color: new THREE.Color(s.color || color), roughness: 0.62, metalness: 0.05,
          flatShading: true, side: THREE.DoubleSide }));
      var q = new THREE.Quaternion();
      if (s.p) { q.set(s.p[1], s.p[2], s.p[3], s.p[0]).normalize(); }
      var local = new THREE.Matrix4().compose(new THREE.Vector3().fromArray(s.center || [0, 0, 0]),
                                              q, new THREE.Vector3(1, 1, 1));
      mesh.matrixAutoUpdate = false;
      mesh.matrix.copy(local);
      mesh.frustumCulled = false;
      scene.add(mesh);
      meshShapes.push({ body: body, local: local, mesh: mesh });
    }

    // instances: [{type, body (index or -1), local (Matrix4), color}]
    var instances = { box: [], cylinder: [], sphere: [] };
    function collect(shapes, body, color) {
      (shapes || []).forEach(function (s) {
        if (s.type === 'mesh') { addTriangleMesh(s, body, color); return; }
        var m = shapeMatrix(s);
        if (m) { instances[s.type].push({ body: body, local: m, color: s.color || color }); }
      });
    }
    options.bodies.forEach(function (b, i) { collect(b.shapes, i, b.color); });
    collect(options.ground, -1, '#9aa3ad');

    var meshes = {};
    var color = new THREE.Color();
    Object.keys(instances).forEach(function (type) {
      var list = instances[type];
      if (!list.length) { return; }
      var material = new THREE.MeshStandardMaterial({ color: 0xffffff, roughness: 0.62,
                                                      metalness: 0.05 });
      var mesh = new THREE.InstancedMesh(geometries[type], material, list.length);
      mesh.instanceMatrix.setUsage(THREE.DynamicDrawUsage);
      list.forEach(function (inst, k) {
        mesh.setColorAt(k, color.set(inst.color));
        if (inst.body < 0) { mesh.setMatrixAt(k, inst.local); }
      });
      mesh.frustumCulled = false;   // instances move; the mesh's own bounds do not follow
      scene.add(mesh);
      meshes[type] = { mesh: mesh, list: list };
    });

    // ------------------------------------------------------------------- grid and axes
    (function addGrid() {
      var g = options.grid, h = g.nHalf * g.step, minor = [], major = [];
      var e1 = new THREE.Vector3().fromArray(g.e1), e2 = new THREE.Vector3().fromArray(g.e2);
      var base = UP.clone().multiplyScalar(g.level);
      function P(a, b) {
        return base.clone().addScaledVector(e1, a).addScaledVector(e2, b);
      }
      for (var i = -g.nHalf; i <= g.nHalf; i++) {
        var a = g.c1 + i * g.step, b = g.c2 + i * g.step;
        (Math.abs(a) < 1e-9 * g.step ? major : minor).push(P(a, g.c2 - h), P(a, g.c2 + h));
        (Math.abs(b) < 1e-9 * g.step ? major : minor).push(P(g.c1 - h, b), P(g.c1 + h, b));
      }
      [[minor, 0x505c70, 0.28], [major, 0x3c465a, 0.6]].forEach(function (set) {
        if (!set[0].length) { return; }
        var geo = new THREE.BufferGeometry().setFromPoints(set[0]);
        var mat = new THREE.LineBasicMaterial({ color: set[1], transparent: true,
                                                opacity: set[2], depthWrite: false });
        scene.add(new THREE.LineSegments(geo, mat));
      });
    })();
    options.axes.forEach(function (ax) {
      var dir = new THREE.Vector3().fromArray(ax[0]);
      var rod = new THREE.Mesh(geometries.rod, new THREE.MeshBasicMaterial({ color: ax[1] }));
      rod.quaternion.setFromUnitVectors(Y, dir);
      rod.scale.set(0.012 * options.axLen, options.axLen, 0.012 * options.axLen);
      rod.position.copy(dir).multiplyScalar(0.5 * options.axLen);
      scene.add(rod);
    });

    // ------------------------------------------------- line-like items (per frame)
    function dynamicMesh(geometry, capacity, materialOptions) {
      var mesh = new THREE.InstancedMesh(geometry, new THREE.MeshStandardMaterial(
        materialOptions || { color: 0xffffff, roughness: 0.5, metalness: 0.1 }), capacity);
      mesh.instanceMatrix.setUsage(THREE.DynamicDrawUsage);
      mesh.count = 0;
      mesh.frustumCulled = false;
      scene.add(mesh);
      return mesh;
    }
    var pools = { rod: null, cone: null, dot: null };
    function ensure(kind, n) {
      var pool = pools[kind];
      if (pool && pool.instanceMatrix.count >= n) { return pool; }
      if (pool) { scene.remove(pool); pool.dispose(); }
      pools[kind] = dynamicMesh(geometries[kind], Math.max(16, 2 * n));
      return pools[kind];
    }
    var mat = new THREE.Matrix4(), P = new THREE.Vector3(), Q = new THREE.Vector3();
    /* a unit y-aligned primitive stretched from a to b with radius r */
    function between(mesh, k, a, b, r) {
      P.fromArray(a);
      Q.fromArray(b);
      tmpV.subVectors(Q, P);
      var len = tmpV.length();
      if (len > 0) { tmpQ.setFromUnitVectors(Y, tmpV.multiplyScalar(1 / len)); }
      else { tmpQ.identity(); }
      tmpS.set(r, Math.max(len, 1e-12), r);
      P.add(Q).multiplyScalar(0.5);
      mesh.setMatrixAt(k, mat.compose(P, tmpQ, tmpS));
    }
    function drawExtras(extras) {
      var segs = extras.segments, cones = extras.cones, dots = extras.dots, k;
      var rods = ensure('rod', segs.length);
      for (k = 0; k < segs.length; k++) {
        between(rods, k, segs[k][0], segs[k][1], segs[k][2]);
        rods.setColorAt(k, color.set(segs[k][3]));
      }
      var heads = ensure('cone', cones.length);
      for (k = 0; k < cones.length; k++) {
        between(heads, k, cones[k][0], cones[k][1], cones[k][2]);
        heads.setColorAt(k, color.set(cones[k][3]));
      }
      var balls = ensure('dot', dots.length);
      for (k = 0; k < dots.length; k++) {
        tmpS.set(dots[k][1], dots[k][1], dots[k][1]);
        balls.setMatrixAt(k, mat.compose(P.fromArray(dots[k][0]), tmpQ.identity(), tmpS));
        balls.setColorAt(k, color.set(dots[k][2]));
      }
      [[rods, segs.length], [heads, cones.length], [balls, dots.length]].forEach(function (x) {
        x[0].count = x[1];
        x[0].instanceMatrix.needsUpdate = true;
        if (x[0].instanceColor) { x[0].instanceColor.needsUpdate = true; }
      });
    }

    // -------------------------------------------------------------------- per frame
    var bodyM = new THREE.Matrix4(), world = new THREE.Matrix4();
    /* view: {C, f, fovy (rad), near, far, width, height, dpr}; poses: [{pos, A (row-major 9)}];
     * extras: {segments: [[a, b, radius, colour]], cones: [[base, tip, radius, colour]],
     * dots: [[point, radius, colour]]} in global axes */
    function render(view, poses, extras) {
      var w = Math.max(1, Math.round(view.width)), h = Math.max(1, Math.round(view.height));
      renderer.setPixelRatio(view.dpr || 1);
      var size = renderer.getSize(tmpV);
      if (size.x !== w || size.y !== h) { renderer.setSize(w, h, false); }
      camera.fov = view.fovy * 180 / Math.PI;
      camera.aspect = w / h;
      camera.near = view.near;
      camera.far = view.far;
      camera.updateProjectionMatrix();
      camera.position.fromArray(view.C);
      camera.lookAt(view.C[0] + view.f[0], view.C[1] + view.f[1], view.C[2] + view.f[2]);

      /* world matrix of a shape of body b: the body's pose times the shape's local matrix */
      function placed(b, local, out) {
        var ps = poses[b], A = ps.A;
        bodyM.set(A[0], A[1], A[2], ps.pos[0],
                  A[3], A[4], A[5], ps.pos[1],
                  A[6], A[7], A[8], ps.pos[2],
                  0, 0, 0, 1);
        return out.multiplyMatrices(bodyM, local);
      }
      Object.keys(meshes).forEach(function (type) {
        var entry = meshes[type], any = false;
        entry.list.forEach(function (inst, k) {
          if (inst.body < 0) { return; }
          entry.mesh.setMatrixAt(k, placed(inst.body, inst.local, world));
          any = true;
        });
        if (any) { entry.mesh.instanceMatrix.needsUpdate = true; }
      });
      meshShapes.forEach(function (entry) {      // triangle meshes: one THREE.Mesh each
        if (entry.body < 0) { return; }
        placed(entry.body, entry.local, entry.mesh.matrix);
        entry.mesh.matrixWorldNeedsUpdate = true;
      });
      drawExtras(extras);
      renderer.render(scene, camera);
    }

    return {
      canvas: canvas,
      render: render,
      revision: THREE.REVISION,
      drawCalls: function () { return renderer.info.render.calls; }
    };
  };
})();
