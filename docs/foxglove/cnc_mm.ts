// cnc: joints in mm (a lathe's X as the diameter), following error in µm.
// Inputs are the recording's setpoints and joint states (m); each setpoint
// message gives one output message with the latest actual position.
import { Input } from "./types";

export const inputs = ["/cnc/joint_setpoints", "/sim/joint_states", "/cnc/machine_file"];
export const output = "/studio_script/cnc_mm";

type Out = { [key: string]: number };

let actual: { [name: string]: number } = {};
let lathe = false;

export default function script(
  event: Input<"/cnc/joint_setpoints"> | Input<"/sim/joint_states"> | Input<"/cnc/machine_file">,
): Out | undefined {
  const msg: any = event.message;
  if (event.topic === "/cnc/machine_file") {
    lathe = /kind\s*=\s*"lathe"/.test(msg.data);
    return undefined;
  }
  if (event.topic === "/sim/joint_states") {
    msg.name.forEach((n: string, i: number) => (actual[n] = msg.position[i]));
    return undefined;
  }
  const out: Out = {};
  msg.name.forEach((n: string, i: number) => {
    const f = lathe && n === "x" ? 2000 : 1000; // mm; lathe X on the diameter
    out[`${n}_setpoint_mm`] = msg.position[i] * f;
    if (n in actual) {
      out[`${n}_actual_mm`] = actual[n] * f;
      out[`${n}_following_error_um`] = (msg.position[i] - actual[n]) * f * 1000;
    }
  });
  return out;
}
