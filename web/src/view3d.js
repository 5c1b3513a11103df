// The twin in 3-D: three.js with the binary glTF the server exports from the twin's meshes (one node per element,
// named by GlobalId, world z up). Elements are coloured by status; a click picks one. Renders on demand only.
import {
  AmbientLight, Box3, Color, DirectionalLight, HemisphereLight, MeshLambertMaterial, PerspectiveCamera, Raycaster,
  Scene, Vector2, Vector3, WebGLRenderer,
} from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";

const STRUCTURE = new Set(["IfcWall", "IfcWallStandardCase", "IfcColumn", "IfcCurtainWall", "IfcDoor", "IfcWindow", "IfcBeam"]);
const FLOORS = new Set(["IfcSlab", "IfcRoof", "IfcCovering"]);

export class TwinView {
  constructor(host, onPick) {
    this.host = host;
    this.onPick = onPick;
    this.meshes = new Map();
    this.scene = new Scene();
    this.scene.background = new Color("#eef2f6");
    this.camera = new PerspectiveCamera(45, 1, 0.1, 2000);
    this.camera.up.set(0, 0, 1);
    this.renderer = new WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
    host.append(this.renderer.domElement);
    this.scene.add(new HemisphereLight("#ffffff", "#8a8f96", 1.6), new AmbientLight("#ffffff", 0.4));
    const sun = new DirectionalLight("#ffffff", 1.6);
    sun.position.set(-20, -30, 40);
    this.scene.add(sun);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.addEventListener("change", () => this.render());
    this.raycaster = new Raycaster();
    let down = null;
    this.renderer.domElement.addEventListener("pointerdown", (e) => (down = [e.clientX, e.clientY]));
    this.renderer.domElement.addEventListener("pointerup", (e) => {
      if (down && Math.hypot(e.clientX - down[0], e.clientY - down[1]) < 4) this.pick(e);
    });
    new ResizeObserver(() => this.resize()).observe(host);
  }

  async load(buffer, elements) {
    const gltf = await new GLTFLoader().parseAsync(buffer, "");
    if (this.root) this.scene.remove(this.root);
    this.root = gltf.scene;
    // the file holds world coordinates, z up, as they are: the camera's up is z instead of turning the model
    this.root.traverse((node) => { if (node.isMesh) this.meshes.set(node.name, node); });
    this.scene.add(this.root);
    for (const element of elements.values()) this.colour(element);
    if (!this.framed) this.frame();
    this.render();
  }

  colour(element) {
    const mesh = this.meshes.get(element.global_id);
    if (!mesh) return;
    const structural = STRUCTURE.has(element.ifc_class) && element.status === "not observed";
    const floor = FLOORS.has(element.ifc_class);
    const colour = floor ? "#d9dde2" : structural ? "#b9bec6" : element.colour;
    mesh.material = new MeshLambertMaterial({ color: colour, transparent: structural, opacity: structural ? 0.55 : 1 });
    mesh.userData = { gid: element.global_id, status: element.status, ifc_class: element.ifc_class };
    if (this.selected === element.global_id) mesh.material.emissive = new Color("#333333");
    this.render();
  }

  // The structure by progress: each permanent element built, not built or not observed (states from /api/progress).
  colourBuilt(structure, colours) {
    for (const [gid, state] of Object.entries(structure)) {
      const mesh = this.meshes.get(gid);
      if (!mesh) continue;
      const key = state === "as planned" || state === "deviating" ? "built" : state === "not built" ? "not built" : "not observed";
      mesh.material = new MeshLambertMaterial({ color: colours[key], transparent: key === "not observed", opacity: key === "not observed" ? 0.5 : 1 });
      mesh.userData = { ...mesh.userData, gid, progress: key };
    }
    this.render();
  }

  select(gid) {
    const previous = this.meshes.get(this.selected);
    if (previous) previous.material.emissive = new Color("#000000");
    this.selected = gid;
    const mesh = this.meshes.get(gid);
    if (mesh) mesh.material.emissive = new Color("#333333");
    this.render();
  }

  frame() {
    const box = new Box3().setFromObject(this.root);
    if (box.isEmpty()) return;
    const centre = box.getCenter(new Vector3());
    const size = box.getSize(new Vector3()).length();
    this.camera.position.set(centre.x - 0.25 * size, centre.y - 0.75 * size, centre.z + 0.55 * size);
    this.controls.target.copy(centre);
    this.controls.update();
    this.framed = true;
  }

  pick(event) {
    const rect = this.renderer.domElement.getBoundingClientRect();
    const pointer = new Vector2(((event.clientX - rect.left) / rect.width) * 2 - 1, -((event.clientY - rect.top) / rect.height) * 2 + 1);
    this.raycaster.setFromCamera(pointer, this.camera);
    const hit = this.raycaster.intersectObjects([...this.meshes.values()], false)
      .find((h) => h.object.userData.gid && !FLOORS.has(h.object.userData.ifc_class));
    if (hit) this.onPick(hit.object.userData.gid);
  }

  resize() {
    const { clientWidth: w, clientHeight: h } = this.host;
    if (!w || !h) return;
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.render();
  }

  render() {
    if (this.pending) return;
    this.pending = true;
    requestAnimationFrame(() => {
      this.pending = false;
      this.renderer.render(this.scene, this.camera);
    });
  }
}
