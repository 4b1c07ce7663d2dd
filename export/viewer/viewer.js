/* plantlod view: glTF trees side by side, playing in time (docs/export.md, "Watching").
 *
 * export/view.py writes the page: this script, three-bundle.js (PLANTLOD_THREE) and a JSON
 * block #plantlod-data = {trees: [{name, branches, glb (base64)}], wind_direction_deg, title}.
 * The model's +Z is up and the exporter already turned it to glTF's +Y, so a model vector
 * (x, y, z) is (x, z, -y) here. The page's location hash may hold `t=SECONDS` (start paused
 * at that time) so that a link, or a test, can show one frame. body[data-state] becomes
 * "ready" once the trees are drawn and "error" on any error, which is also shown and logged.
 */
(function () {
  'use strict';
  var T = window.PLANTLOD_THREE;
  var data = JSON.parse(document.getElementById('plantlod-data').textContent);
  var statusLine = document.getElementById('status');

  function fail(message) {
    var text = String(message && message.message ? message.message : message);
    statusLine.textContent = 'error: ' + text;
    document.body.dataset.state = 'error';
    console.error('plantlod view: ' + text);
  }
  window.addEventListener('error', function (e) { fail(e.message); });
  window.addEventListener('unhandledrejection', function (e) { fail(e.reason); });

  var hash = new URLSearchParams(window.location.hash.slice(1));
  var canvas = document.getElementById('view');
  var renderer = new T.WebGLRenderer({ canvas: canvas, antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  var scene = new T.Scene();
  scene.background = new T.Color(0xeef2f5);
  scene.add(new T.HemisphereLight(0xffffff, 0x6b7a58, 2.2));
  var sun = new T.DirectionalLight(0xffffff, 1.6);
  sun.position.set(4, 10, 7);
  scene.add(sun);
  var camera = new T.PerspectiveCamera(35, 1, 0.01, 10000);
  var controls = new T.OrbitControls(camera, canvas);
  var bark = new T.MeshStandardMaterial({ color: 0x6b4a2f, roughness: 0.9 });
  var leaf = new T.MeshStandardMaterial({ color: 0x3f8f3a, roughness: 0.8 });

  var play = document.getElementById('play');
  var slider = document.getElementById('time');
  var readout = document.getElementById('clock');
  var labels = document.getElementById('labels');
  var mixers = [];
  var placed = [];
  var duration = 0;
  var time = 0;
  var playing = true;

  function decode(base64) {
    var bytes = atob(base64);
    var out = new Uint8Array(bytes.length);
    for (var i = 0; i < bytes.length; i++) out[i] = bytes.charCodeAt(i);
    return out.buffer;
  }

  function build(gltfs) {
    var gap = 0;
    var boxes = gltfs.map(function (gltf) {
      gltf.scene.traverse(function (node) {
        if (node.isMesh) node.material = node.name.indexOf('leaf') === 0 ? leaf : bark;
      });
      gltf.scene.updateMatrixWorld(true);
      var box = new T.Box3().setFromObject(gltf.scene);
      gap = Math.max(gap, 0.35 * (box.max.y - box.min.y));
      return box;
    });
    var x = 0;
    gltfs.forEach(function (gltf, k) {
      var box = boxes[k];
      var width = Math.max(box.max.x - box.min.x, box.max.z - box.min.z);
      gltf.scene.position.set(x + width / 2 - (box.min.x + box.max.x) / 2, 0,
                              -(box.min.z + box.max.z) / 2);
      x += width + gap;
      scene.add(gltf.scene);
      placed.push({ root: gltf.scene, height: box.max.y - box.min.y, tree: data.trees[k] });
      if (gltf.animations.length) {
        var mixer = new T.AnimationMixer(gltf.scene);
        gltf.animations.forEach(function (clip) {
          mixer.clipAction(clip).play();
          duration = Math.max(duration, clip.duration);
        });
        mixers.push(mixer);
      }
      var label = document.createElement('div');
      label.className = 'label';
      var count = data.trees[k].branches;
      label.textContent = data.trees[k].name +
        (count === null ? '' : ' \u2014 ' + count.toLocaleString('en') + ' branches');
      labels.appendChild(label);
      placed[k].label = label;
    });
    var all = new T.Box3();
    placed.forEach(function (p) { all.expandByObject(p.root); });
    var size = all.getSize(new T.Vector3());
    var centre = all.getCenter(new T.Vector3());
    var span = Math.max(size.x, size.y, 1e-3);
    var grid = new T.GridHelper(1.2 * span, 24, 0x9aa7b0, 0xc9d1d6);
    grid.position.set(centre.x, all.min.y, centre.z);
    scene.add(grid);
    var a = (data.wind_direction_deg || 0) * Math.PI / 180;
    var toward = new T.Vector3(Math.cos(a), 0, -Math.sin(a));      // model (cos a, sin a, 0)
    var arrowLength = 0.25 * span;
    var arrowMiddle = new T.Vector3(centre.x, all.min.y + 0.005 * span, all.max.z + 0.12 * span);
    var arrow = new T.ArrowHelper(toward, arrowMiddle.clone().addScaledVector(toward, -arrowLength / 2),
      arrowLength, 0x2f6fd0, 0.2 * arrowLength, 0.1 * arrowLength);
    scene.add(arrow);
    document.getElementById('wind').textContent =
      'wind toward ' + (data.wind_direction_deg || 0) + '\u00b0 (blue arrow; 0\u00b0 = +x, 90\u00b0 = +y)';
    resize();
    var tan = Math.tan(camera.fov * Math.PI / 360);
    var distance = 1.3 * Math.max(size.y / 2 / tan, size.x / 2 / (camera.aspect * tan)) + size.z / 2;
    controls.target.copy(centre);
    camera.position.set(centre.x, centre.y + 0.5 * size.y, centre.z + distance);
    camera.near = span / 1000;
    camera.far = span * 100;
    controls.update();
    slider.max = String(duration);
    slider.step = String(Math.max(duration / 1000, 1e-3));
    slider.disabled = duration === 0;
    if (hash.has('t')) {
      time = Math.min(Math.max(Number(hash.get('t')) || 0, 0), duration);
      playing = false;
    }
    showTime();
    renderer.render(scene, camera);
    if (document.body.dataset.state !== 'error') document.body.dataset.state = 'ready';
    statusLine.textContent = '';
    requestAnimationFrame(tick);
  }

  function showTime() {
    var t = duration > 0 ? Math.min(time, duration * (1 - 1e-9)) : 0;
    mixers.forEach(function (m) { m.setTime(t); });
    slider.value = String(time);
    readout.textContent = time.toFixed(2) + ' / ' + duration.toFixed(2) + ' s';
    play.textContent = playing ? 'pause' : 'play';
  }

  function placeLabels() {
    var rect = canvas.getBoundingClientRect();
    placed.forEach(function (p) {
      var v = new T.Vector3().setFromMatrixPosition(p.root.matrixWorld);
      v.y += p.height;                                   // above the tree's rest top
      v.project(camera);
      var half = p.label.offsetWidth / 2 + 4;            // kept inside the canvas
      var x = Math.min(Math.max((v.x + 1) / 2 * rect.width, half), rect.width - half);
      p.label.style.left = (rect.left + x) + 'px';
      p.label.style.top = (rect.top + (1 - v.y) / 2 * rect.height - 26) + 'px';
    });
  }

  function resize() {
    var w = canvas.clientWidth, h = canvas.clientHeight;
    renderer.setSize(w, h, false);
    camera.aspect = w / Math.max(h, 1);
    camera.updateProjectionMatrix();
  }

  var last = null;
  function tick(now) {
    if (last !== null && playing && duration > 0) {
      time = (time + (now - last) / 1000) % duration;
      showTime();
    }
    last = now;
    controls.update();
    renderer.render(scene, camera);
    placeLabels();
    requestAnimationFrame(tick);
  }

  play.addEventListener('click', function () { playing = !playing; showTime(); });
  slider.addEventListener('input', function () { time = Number(slider.value); showTime(); });
  window.addEventListener('resize', resize);

  var loader = new T.GLTFLoader();
  statusLine.textContent = 'loading ' + data.trees.length + ' tree(s)\u2026';
  Promise.all(data.trees.map(function (t) { return loader.parseAsync(decode(t.glb), ''); }))
    .then(build).catch(fail);
})();
