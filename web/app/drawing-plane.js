// Where a stroke drawn on the screen lands in 3D, and the cursor marker that shows it.
//
// A stroke lies on a plane facing the camera through the joint of the selected character
// nearest the cursor (on screen) when the stroke begins; the plane is held for the whole
// stroke. Strokes start on or next to the limb they pose, so the stroke lands at that limb's
// depth from any viewing angle (an arm seen from the side is drawn at the arm, not through the
// middle of the body), and holding the plane keeps the stroke flat and steady even when the
// cursor passes over other bones. Before a stroke, the marker shows the plane the next stroke
// would use: a ring on it under the cursor and a dot on the joint that picked it.

import * as THREE from 'three';

export class DrawingPlane {
  /** `viewport`: the Viewport; `selected()`: the selected Character or null. */
  constructor(viewport, selected) {
    this.viewport = viewport;
    this.selected = selected;
    this.plane = null; // held while a stroke is drawn
    this.raycaster = new THREE.Raycaster();

    const ringMaterial = new THREE.MeshBasicMaterial({
      color: 0xffffff,
      depthTest: false,
      transparent: true,
      opacity: 0.85,
      side: THREE.DoubleSide,
    });
    this.marker = new THREE.Group();
    this.marker.name = 'cursor marker';
    const ring = new THREE.Mesh(new THREE.RingGeometry(0.8, 1, 32), ringMaterial);
    const dot = new THREE.Mesh(new THREE.CircleGeometry(0.18, 16), ringMaterial);
    this.marker.add(ring, dot);
    this.disc = new THREE.Mesh(
      new THREE.CircleGeometry(1, 48),
      new THREE.MeshBasicMaterial({
        color: 0x8fd3ff,
        depthTest: false,
        depthWrite: false,
        transparent: true,
        opacity: 0.05,
        side: THREE.DoubleSide,
      }),
    );
    this.disc.name = 'drawing plane';
    this.anchor = new THREE.Mesh(new THREE.SphereGeometry(1, 12, 8), ringMaterial);
    this.anchor.name = 'drawing plane joint';
    for (const m of [this.marker, this.disc, this.anchor]) {
      m.renderOrder = 20;
      m.visible = false;
      viewport.scene.add(m);
    }
  }

  /** The plane facing the camera through the selected character's joint nearest `screen`. */
  planeAt(screen) {
    const character = this.selected();
    const camera = this.viewport.camera;
    const normal = camera.getWorldDirection(new THREE.Vector3());
    let through = this.viewport.controls.target.clone();
    if (character) {
      let best = Infinity;
      for (const p of character.worldPositions()) {
        const [x, y, z] = this.viewport.project([p.x, p.y, p.z]);
        const d = (x - screen[0]) ** 2 + (y - screen[1]) ** 2;
        if (z < 1 && d < best) {
          best = d;
          through = p;
        }
      }
    }
    return { plane: new THREE.Plane().setFromNormalAndCoplanarPoint(normal, through), through };
  }

  /** Where the ray under `screen` meets `plane` (page space), or null (plane behind the camera). */
  pointOn(plane, screen) {
    this.raycaster.setFromCamera(this.viewport.ndc(screen), this.viewport.camera);
    return this.raycaster.ray.intersectPlane(plane, new THREE.Vector3());
  }

  /** Starts a stroke at `screen`: picks and holds the plane; the first point. */
  begin(screen) {
    const { plane, through } = this.planeAt(screen);
    this.plane = plane;
    this.through = through;
    return this.pointOn(plane, screen);
  }

  /** A point of the stroke being drawn. */
  point(screen) {
    return this.plane ? this.pointOn(this.plane, screen) : null;
  }

  end() {
    this.plane = null;
  }

  /** Moves the marker under the cursor (on the held plane, or the one a stroke would use). */
  hover(screen) {
    const { plane, through } = this.plane ? { plane: this.plane, through: this.through } : this.planeAt(screen);
    const point = this.pointOn(plane, screen);
    if (!point) {
      this.hide();
      return;
    }
    const camera = this.viewport.camera;
    const size = camera.position.distanceTo(point) * 0.012;
    this.marker.position.copy(point);
    this.marker.quaternion.copy(camera.quaternion);
    this.marker.scale.setScalar(size);
    this.disc.position.copy(through);
    this.disc.quaternion.copy(camera.quaternion);
    this.disc.scale.setScalar(0.35 * (this.selected()?.placement.scale.x ?? 1) * (this.selected()?.height ?? 1));
    this.anchor.position.copy(through);
    this.anchor.scale.setScalar(size * 0.35);
    for (const m of [this.marker, this.disc, this.anchor]) m.visible = true;
    this.marker.children[0].material.color.setHex(this.plane ? 0x38e1a0 : 0xffffff);
  }

  hide() {
    for (const m of [this.marker, this.disc, this.anchor]) m.visible = false;
  }
}
