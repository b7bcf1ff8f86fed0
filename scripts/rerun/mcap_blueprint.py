"""The Rerun blueprint for a cnc recording opened with Rerun's own MCAP
loader (no `cnc bag rrd`): docs/rerun/cnc_mcap.rbl.

    python3 scripts/rerun/mcap_blueprint.py [-o docs/rerun/cnc_mcap.rbl]

Rerun's loader maps each topic to an entity of its name (metres, the
recording's wall-clock timeline `message_log_time`); the blueprint lays
them out: the 3D view with the tool path so far (`/cnc/toolpath`: the
recordings write the path so far every second, so the newest cloud at the
cursor grows as the timeline is scrubbed), the tool (`/cnc/tool_pose`) and
its frame (`/tf`); each joint's setpoint and actual position; the program;
the status. A blueprint applies to recordings of its application id,
`cnc_mcap`, so convert with that id (README "Rerun: watching a recording"):

    rerun mcap convert IN.mcap --application-id cnc_mcap -o OUT.rrd
    rerun OUT.rrd docs/rerun/cnc_mcap.rbl

Needs rerun-sdk 0.41 (scripts/ros_peer/requirements.txt).
"""
import argparse
import os

import rerun.blueprint as rrb

APP_ID = "cnc_mcap"
ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
OUT = os.path.join(ROOT, "docs", "rerun", "cnc_mcap.rbl")
TIMELINE = "message_log_time"


def blueprint():
    view3d = rrb.Spatial3DView(
        origin="/",
        contents=["/cnc/toolpath", "/cnc/tool_pose", "/tf"],
        name="tool path so far (/cnc/toolpath), tool (/cnc/tool_pose, /tf), m",
        background=(24, 26, 30),
        line_grid=rrb.LineGrid3D(visible=True, spacing=0.01, color=(70, 70, 70, 80)),
    )
    joints = rrb.Vertical(
        rrb.TimeSeriesView(origin="/cnc/joint_setpoints/position", name="setpoints (m)",
                           plot_legend=rrb.PlotLegend(visible=True, corner=rrb.Corner2D.RightBottom)),
        rrb.TimeSeriesView(origin="/sim/joint_states/position", name="actual (m)",
                           plot_legend=rrb.PlotLegend(visible=True, corner=rrb.Corner2D.RightBottom)),
        rrb.TimeSeriesView(origin="/sim/joint_states/velocity", name="actual velocity (m/s)",
                           plot_legend=rrb.PlotLegend(visible=True, corner=rrb.Corner2D.RightBottom)),
    )
    left = rrb.Vertical(
        view3d,
        rrb.Horizontal(
            rrb.TextDocumentView(origin="/cnc/program", name="program"),
            rrb.DataframeView(origin="/cnc/status", name="status"),
            column_shares=[2, 3],
        ),
        row_shares=[3, 1.4],
    )
    return rrb.Blueprint(
        rrb.Horizontal(left, joints, column_shares=[1.15, 1]),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="expanded", timeline=TIMELINE),
    )


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("-o", "--out", default=OUT)
    a = ap.parse_args(argv)
    os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
    blueprint().save(APP_ID, a.out)
    print(f"{a.out}: blueprint for application id {APP_ID}")


if __name__ == "__main__":
    main()
