// SPDX-License-Identifier: AGPL-3.0-or-later
// portal_flow.mjs - drives the portal in Debian's headless chromium with
// playwright-core (no browser download); started by test_portal.py, which
// runs the server and checks what this script saves.  Environment: URL,
// KEY_A, KEY_B, ADMIN_KEY, MESH, OUT (artifact directory).  Writes
// OUT/result.json, OUT/layer500.png (the PNG the page received),
// OUT/layer500.gray (the pixels the page shows, one gray byte each),
// OUT/download.sl1 and screenshots OUT/*.png.
import { chromium } from "playwright-core";
import { writeFileSync } from "node:fs";
import { join } from "node:path";

const env = process.env;
const OUT = env.OUT;
const result = { steps: [], progress: [], problems: [], http_errors: [] };

function step(name) {
  result.steps.push(name);
  console.log("step:", name);
}

async function shot(page, name) {
  await page.screenshot({ path: join(OUT, name + ".png"), fullPage: true });
}

function watch(page, label) {
  page.on("response", (r) => {
    if (r.status() >= 400) result.http_errors.push(label + " " + r.status() + " " + new URL(r.url()).pathname);
  });
  page.on("console", (m) => {
    if (/^Failed to load resource/.test(m.text())) return; // listed by status above
    if (m.type() === "error" || /Content Security Policy/i.test(m.text())) {
      result.problems.push(label + " console " + m.type() + ": " + m.text());
    }
  });
  page.on("pageerror", (e) => result.problems.push(label + " pageerror: " + e.message));
}

async function signIn(page, key) {
  await page.goto(env.URL + "/");
  await page.getByLabel("API key").fill(key);
  await page.getByRole("button", { name: "Sign in" }).click();
  await page.locator("#app").waitFor({ state: "visible" });
}

const browser = await chromium.launch({
  executablePath: "/usr/bin/chromium",
  headless: true,
  // Root in a container: no sandbox; a small /dev/shm: none; WebGL in software.
  args: ["--no-sandbox", "--disable-dev-shm-usage", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"],
});
try {
  // ---- tenant A: the whole flow ----
  const ctxA = await browser.newContext({ acceptDownloads: true, viewport: { width: 1200, height: 900 } });
  const page = await ctxA.newPage();
  watch(page, "A");
  await signIn(page, env.KEY_A);
  await page.locator("#tenant-ui").waitFor({ state: "visible" });
  result.key_in_storage = await page.evaluate(() => sessionStorage.getItem("infilld.apiKey") !== null);
  result.url_after_signin = page.url();
  step("signed in");
  await shot(page, "01-signed-in");

  await page.locator("#file").setInputFiles(env.MESH);
  await page.locator("#upload-status").filter({ hasText: "Uploaded" }).waitFor();
  result.upload_bar = await page.locator("#upload-progress").evaluate((e) => e.value);
  result.analysis = await page.locator("#analysis").innerText();
  await page.locator("#configure").waitFor({ state: "visible" });
  step("uploaded");
  await page.locator("#view").focus();
  await page.keyboard.press("ArrowLeft");
  await shot(page, "02-uploaded");

  // A value the page accepts (in the table's range) that the server
  // refuses: 5000 mm does not fit the SL1.  The 422 shows at the field.
  await page.locator("#f-engine").selectOption("solid");
  await page.locator("#f-format").selectOption("sl1");
  await page.locator("#p-height_mm").fill("5000");
  await page.getByRole("button", { name: "Submit job" }).click();
  const fieldErr = page.locator("#p-height_mm-error");
  await fieldErr.filter({ hasText: /\S/ }).waitFor();
  result.field_error = await fieldErr.innerText();
  result.field_invalid = await page.locator("#p-height_mm").getAttribute("aria-invalid");
  step("422 at its field");
  await shot(page, "03-field-error");

  await page.locator("#p-height_mm").fill("50");
  await page.getByRole("button", { name: "Submit job" }).click();
  await page.locator("#job").waitFor({ state: "visible" });
  result.job_id = await page.locator("#job-id").innerText();
  const deadline = Date.now() + 240000;
  for (;;) {
    // progress and state in one turn of the page's event loop: read one
    // after the other, the final snapshot could land between them
    const [v, st] = await page.locator("#job").evaluate((j) => [
      j.querySelector("#job-progress").value,
      j.querySelector("#job-state").innerText,
    ]);
    if (result.progress[result.progress.length - 1] !== v) result.progress.push(v);
    if (st === "succeeded" || st === "failed" || st === "cancelled") {
      result.final_state = st;
      break;
    }
    if (Date.now() > deadline) throw new Error("the job did not finish in time");
    await page.waitForTimeout(100);
  }
  step("job " + result.final_state);
  await page.locator("#result").waitFor({ state: "visible" });
  await page.locator("#layer-img[data-layer='0']").waitFor();
  await shot(page, "04-finished");

  // The layer slider to 500: the PNG the page received and what it shows.
  // The response is taken on its way to the page (route.fetch) and passed
  // on unchanged, so the bytes saved are the bytes the page received.
  let received = null;
  await page.route("**/layers/500", async (route) => {
    const r = await route.fetch();
    received = await r.body();
    await route.fulfill({ response: r, body: received });
  });
  await page.locator("#layer").fill("500");
  await page.locator("#layer-img[data-layer='500']").waitFor();
  writeFileSync(join(OUT, "layer500.png"), received);
  await page.waitForFunction(() => document.getElementById("layer-img").complete);
  result.layer_count = await page.locator("#layer-count").innerText();
  const gray = await page.evaluate(() => {
    const img = document.getElementById("layer-img");
    const c = document.createElement("canvas");
    c.width = img.naturalWidth;
    c.height = img.naturalHeight;
    const g = c.getContext("2d", { willReadFrequently: true });
    g.drawImage(img, 0, 0);
    const d = g.getImageData(0, 0, c.width, c.height).data;
    const out = new Uint8Array(c.width * c.height);
    for (let i = 0; i < out.length; i++) out[i] = d[i * 4];
    let s = "";
    for (let i = 0; i < out.length; i += 32768) s += String.fromCharCode(...out.subarray(i, i + 32768));
    return { w: c.width, h: c.height, b64: btoa(s) };
  });
  writeFileSync(join(OUT, "layer500.gray"), Buffer.from(gray.b64, "base64"));
  result.layer500_size = [gray.w, gray.h];
  step("layer 500 shown");
  await shot(page, "05-layer-500");

  const dl = page.waitForEvent("download");
  await page.locator("#download").click();
  const download = await dl;
  await download.saveAs(join(OUT, "download.sl1"));
  result.download_name = download.suggestedFilename();
  step("downloaded");

  // A G-code job of the same part: its layers are drawings by role.
  await page.locator("#f-format").selectOption("gcode");
  result.gcode_printer = await page.locator("#f-printer").inputValue();
  await page.locator("#p-height_mm").fill("50");
  await page.getByRole("button", { name: "Submit job" }).click();
  await page.waitForFunction((old) => document.getElementById("job-id").textContent !== old, result.job_id);
  await page.locator("#job-state").filter({ hasText: /^(succeeded|failed|cancelled)$/ }).waitFor({ timeout: 240000 });
  result.gcode_state = await page.locator("#job-state").innerText();
  await page.locator("#layer-img[data-layer='0']").waitFor();
  await page.locator("#layer").fill("100");
  await page.locator("#layer-img[data-layer='100']").waitFor();
  await page.waitForFunction(() => document.getElementById("layer-img").complete);
  result.gcode_layer = await page.locator("#layer-img").evaluate((i) => [i.naturalWidth, i.naturalHeight]);
  result.gcode_layers = await page.locator("#layer-count").innerText();
  result.gcode_legend = await page.locator("#legend").isVisible();
  step("G-code layer 100 shown");
  await shot(page, "08-gcode-layer-100");

  result.jobs_listed_a = await page.locator("#jobs-table tbody tr").count();
  // The state filter: both jobs succeeded, none is queued.
  const rows = page.locator("#jobs-table tbody tr");
  await page.locator("#jobs-state").selectOption("queued");
  await page.waitForFunction(() => document.querySelectorAll("#jobs-table tbody tr").length === 0);
  result.jobs_queued_a = await rows.count();
  await page.locator("#jobs-state").selectOption("succeeded");
  await page.waitForFunction(() => document.querySelectorAll("#jobs-table tbody tr").length > 0);
  result.jobs_succeeded_a = await rows.count();

  // Cancel: a hollow job of the femur runs for seconds; the Cancel button
  // ends it and the page shows the cancelled state.
  await page.locator("#f-format").selectOption("sl1");
  await page.locator("#f-engine").selectOption("hollow");
  await page.locator("#p-height_mm").fill("50");
  const before = await page.locator("#job-id").textContent();
  await page.getByRole("button", { name: "Submit job" }).click();
  await page.waitForFunction((old) => document.getElementById("job-id").textContent !== old, before);
  await page.locator("#cancel").waitFor({ state: "visible" });
  await page.locator("#cancel").click();
  await page.locator("#job-state").filter({ hasText: /^(succeeded|failed|cancelled)$/ }).waitFor({ timeout: 120000 });
  result.cancel_state = await page.locator("#job-state").innerText();
  result.cancel_button_hidden = await page.locator("#cancel").isHidden();
  step("cancelled");
  await shot(page, "09-cancelled");
  await ctxA.close();

  // ---- tenant B: sees none of A's jobs ----
  const ctxB = await browser.newContext({ viewport: { width: 1200, height: 900 } });
  const pb = await ctxB.newPage();
  watch(pb, "B");
  // B signs in with the keyboard alone: Tab past the skip link to the key
  // field (its focus ring must show), type, Enter.
  await pb.goto(env.URL + "/");
  await pb.keyboard.press("Tab");
  await pb.keyboard.press("Tab");
  result.b_focus = await pb.evaluate(() => {
    const el = document.activeElement;
    const st = getComputedStyle(el);
    return { id: el.id, outline: st.outlineStyle, width: st.outlineWidth };
  });
  await pb.keyboard.type(env.KEY_B);
  await pb.keyboard.press("Enter");
  await pb.locator("#app").waitFor({ state: "visible" });
  await pb.locator("#tenant-ui").waitFor({ state: "visible" });
  await pb.waitForTimeout(500);
  result.jobs_listed_b = await pb.locator("#jobs-table tbody tr").count();
  result.b_status_on_a_job = await pb.evaluate(async (id) => {
    const key = sessionStorage.getItem("infilld.apiKey");
    const r = await fetch("/v1/jobs/" + id + "/layers/500", { headers: { Authorization: "Bearer " + key } });
    return r.status;
  }, result.job_id);
  step("tenant B sees no jobs");
  await shot(pb, "06-tenant-b");
  await ctxB.close();

  // ---- admin: tenants and the queue ----
  const ctxC = await browser.newContext({ viewport: { width: 1200, height: 900 } });
  const pc = await ctxC.newPage();
  watch(pc, "admin");
  await signIn(pc, env.ADMIN_KEY);
  await pc.locator("#admin").waitFor({ state: "visible" });
  await pc.locator("#tenant-table tbody tr").first().waitFor();
  result.admin_tenants = await pc.locator("#tenant-table tbody th").allInnerTexts();
  result.admin_queue = await pc.locator("#queue-table").innerText();
  step("admin sees tenants and queue");
  await shot(pc, "07-admin");
  await ctxC.close();
} catch (e) {
  result.error = String(e && e.stack ? e.stack : e);
} finally {
  await browser.close();
  writeFileSync(join(OUT, "result.json"), JSON.stringify(result, null, 2));
}
process.exit(result.error ? 1 : 0);
