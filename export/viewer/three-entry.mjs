// The parts of three.js the `plantlod view` page uses, bundled by export/viewer/vendor.sh into
// three-bundle.js as one classic script that defines the global PLANTLOD_THREE.
export {
  AmbientLight, AnimationMixer, ArrowHelper, Box3, Color, DirectionalLight, GridHelper,
  HemisphereLight, MeshStandardMaterial, PerspectiveCamera, Scene, Vector3, WebGLRenderer,
} from 'three';
export { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
export { OrbitControls } from 'three/addons/controls/OrbitControls.js';
