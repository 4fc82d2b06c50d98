#!/usr/bin/env node
// A minimal external AV stack in Node.js, speaking sitcov's protocol v1 (docs/protocol.md).
//
// The same stack as examples/python_stack.py, to show that the boundary is language-neutral:
// JSON lines on stdin/stdout, logs on stderr, answer `hello`, `reset` (-> `ready`) and every
// `step` (-> `control`), exit on `close` or when stdin ends. It follows the route (steers
// towards a point a few metres ahead, holds 25 km/h) and brakes fully for the rest of the
// run once a confident car detection near the image centre is large enough to be close.
// Only Node's standard library is used.
//
//   sitcov run --runs 50 --db node.db --av-cmd "node examples/node_stack.js"

'use strict';

const readline = require('readline');

const TARGET_SPEED = 25.0 / 3.6; // cruise speed [m/s]
const LOOKAHEAD = 3.0; // steer towards the route point at least this far ahead [m] ...
const LOOKAHEAD_TIME = 0.5; // ... plus this many seconds of travel [s]
const STEER_GAIN = 0.9; // steer command per radian of heading error [1/rad]
const SPEED_GAIN = 0.3; // throttle (or brake) per m/s of speed error [s/m]
const MIN_SCORE = 0.5; // detections below this score are ignored [-]
const CENTRE = [0.05, 0.98]; // box centre must lie in this share of the image width [-]
const MIN_WIDTH = 0.12; // ... and the box cover at least this share of it (close) [-]

const clamp = (v, lo, hi) => Math.max(lo, Math.min(hi, v));

let route = [];
let width = 800;
let index = 0;
let braking = false;

function threat(det) {
  const [x0, , x1] = det.box;
  const centre = (0.5 * (x0 + x1)) / width;
  return det.label === 'car' && det.score >= MIN_SCORE &&
    centre > CENTRE[0] && centre < CENTRE[1] && (x1 - x0) / width >= MIN_WIDTH;
}

function steer(ego) {
  const reach = LOOKAHEAD + LOOKAHEAD_TIME * ego.speed;
  while (index < route.length - 1 &&
         Math.hypot(route[index][0] - ego.x, route[index][1] - ego.y) < reach) {
    index += 1;
  }
  const [tx, ty] = route[index];
  let error = Math.atan2(ty - ego.y, tx - ego.x) - ego.yaw;
  error = Math.atan2(Math.sin(error), Math.cos(error)); // wrap to (-pi, pi]
  return clamp(STEER_GAIN * error, -0.8, 0.8);
}

function step(msg) {
  if (!braking && msg.detections) braking = msg.detections.some(threat);
  const s = steer(msg.ego);
  if (braking) return { type: 'control', throttle: 0, brake: 1, steer: s, info: { aeb: true } };
  const u = SPEED_GAIN * (TARGET_SPEED - msg.ego.speed);
  return { type: 'control', throttle: clamp(u, 0, 0.75), brake: clamp(-u, 0, 0.3), steer: s };
}

const send = (message) => process.stdout.write(JSON.stringify(message) + '\n');

const input = readline.createInterface({ input: process.stdin, terminal: false });
input.on('line', (line) => {
  if (!line.trim()) return;
  const msg = JSON.parse(line);
  switch (msg.type) {
    case 'step':
      send(step(msg));
      break;
    case 'reset':
      route = msg.route.length ? msg.route : [msg.goal];
      width = msg.camera.width;
      index = 0;
      braking = false;
      send({ type: 'ready' });
      break;
    case 'hello':
      if (msg.protocol !== 1) {
        console.error(`unsupported protocol ${msg.protocol}`);
        process.exit(1);
      }
      send({ type: 'hello', protocol: 1, name: 'node-example', wants: 'detections' });
      break;
    case 'close':
      input.close();
      break;
    default:
      console.error(`ignoring message of type ${msg.type}`);
  }
});
input.on('close', () => process.exit(0));
