// The operator dashboard: one module per panel; the API is the only thing it talks to.

import { get, toast } from "./api.js";
import { connect } from "./live.js";
import { mountAction } from "./panels/action.js";
import { mountCalibration } from "./panels/calibration.js";
import { mountCameras } from "./panels/cameras.js";
import { mountPeople } from "./panels/people.js";
import { mountStatus } from "./panels/status.js";
import { mountStudy } from "./panels/study.js";
import { mountViewer } from "./panels/viewer.js";

// The study module's panels; the dashboard still works without them.
async function optionalModule(load, name) {
  try {
    return await load();
  } catch (err) {
    console.warn(`${name} is not available`, err);
    return null;
  }
}

async function main() {
  let info;
  try {
    info = await get("/info");
  } catch (err) {
    toast(err.status === 401 ? "operator token required: open the link printed by `cavewalk serve`" : err.message);
    return;
  }
  mountStatus();
  mountAction();
  mountPeople();
  mountCameras(info);
  mountViewer(info);
  mountCalibration(info);

  const planner = await optionalModule(() => import("./panels/planner.js"), "planner.js");
  if (planner) planner.mountPlanner(document.getElementById("planner-mount"));

  const questionnaire = await optionalModule(() => import("./questionnaire.js"), "questionnaire.js");
  const qMount = document.getElementById("questionnaire-mount");
  mountStudy({
    onSelectSession(session) {
      document.getElementById("questionnaire-session").textContent =
        `session ${session.id}: ${session.participant_code}, ${session.condition}`;
      if (questionnaire) {
        qMount.replaceChildren();
        questionnaire.mountQuestionnaire(qMount, { sessionId: session.id });
      } else {
        qMount.textContent = "The questionnaire forms are not installed.";
      }
    },
  });
  const analysis = await optionalModule(() => import("./analysis.js"), "analysis.js");
  if (analysis) analysis.mountAnalysis(document.getElementById("analysis-mount"));
  connect();
}

main();
