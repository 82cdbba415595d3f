// The operator dashboard: one module per panel; the API is the only thing it talks to.

import { get, toast } from "./api.js";
import { connect } from "./live.js";
import { mountAction } from "./panels/action.js";
import { mountAlarm } from "./panels/alarm.js";
import { mountCalibration } from "./panels/calibration.js";
import { mountCameras } from "./panels/cameras.js";
import { mountHold } from "./panels/hold.js";
import { mountPeople } from "./panels/people.js";
import { mountScript } from "./panels/script.js";
import { mountSession } from "./panels/session.js";
import { mountStatus } from "./panels/status.js";
import { mountSteps } from "./panels/steps.js";
import { mountStudy } from "./panels/study.js";
import { mountViewer } from "./panels/viewer.js";
import { mountQuestionnaire } from "./questionnaire.js";

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
  mountAlarm();
  mountHold();
  mountAction();
  mountSteps(document.getElementById("step-strip-slot"));
  mountPeople();
  mountCameras(info);
  mountViewer(info);
  mountCalibration(info);
  const script = mountScript();
  const detail = mountSession();
  const qMount = document.getElementById("questionnaire-mount");
  const qTitle = document.getElementById("questionnaire-session");
  let formSession = null;
  const study = mountStudy({
    onSelectSession(session, { refreshOnly }) {
      detail.show(session, { refreshOnly });
      if (refreshOnly && formSession === session.id) return;
      script.show(session);
      // the form is replaced at once: never another session's form on screen
      formSession = session.id;
      qTitle.textContent = `session ${session.id}: ${session.participant_code}, ${session.condition}`;
      qMount.replaceChildren();
      mountQuestionnaire(qMount, { session, onSubmitted: () => script.refresh() });
    },
  });
  const analysis = await optionalModule(() => import("./analysis.js"), "analysis.js");
  if (analysis) analysis.mountAnalysis(document.getElementById("analysis-mount"));
  // panels of other areas, each its own module
  const planner = await optionalModule(() => import("./panels/planner.js"), "planner.js");
  if (planner) planner.mountPlanner(document.getElementById("planner-mount"));
  const takes = await optionalModule(() => import("./panels/takes.js"), "takes.js");
  if (takes) takes.mountTakes(document.getElementById("recording-panel"));
  const models = await optionalModule(() => import("./panels/models.js"), "models.js");
  if (models) models.mountModels(document.getElementById("models-panel"));
  connect();
  return study;
}

main();
