"""The daemon's page (GET /) in a real headless Chromium (Debian's, driven by
selenium): a realdds camera appears on it within a second of the daemon listing it
and goes on 'stopping'; its details and description open; a camera in recovery is
highlighted, and keeps its colour under the pointer; the selected row stands out and
its details scroll into view (a phone too), a #id link opens a camera, times show
UTC, how long ago and local time; option values and ranges read as `rs-discover
describe` prints them; the table is marked stale while the daemon is unreachable;
the network view lists the realdds server; a camera's details say who uses it. The spec is served at
/openapi.yaml. A screenshot of the page is kept as a test artifact
(RSD_BUILD_DIR/web-page.png), phone-sized and dark too."""
import json
import os
import shutil
import time

import pytest
from camera_spec import SPEC
from conftest import device_info, wait_for

ARTIFACTS = os.environ.get("RSD_BUILD_DIR", "/tmp")


@pytest.fixture
def browser():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = shutil.which("chromium")
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                "--window-size=1280,800"):
        options.add_argument(arg)
    driver = webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=options)
    yield driver
    driver.quit()


def rows(driver, table="devices"):
    """A table as the user sees it, {first cell: {text, class, id}}, read in one go:
    the page redraws its tables as events come, so elements found one by one go stale."""
    found = driver.execute_script("""
        return [...document.querySelectorAll('#' + arguments[0] + ' tbody tr')].map((tr) => ({
          first: tr.cells[0].innerText, text: tr.innerText, cls: tr.className, id: tr.dataset.id || ''}));""",
                                  table)
    return {r["first"]: {"text": r["text"], "class": r["cls"], "id": r["id"]} for r in found}


def wait_rows(driver, predicate, timeout, what):
    """Polls the page every 20 ms; returns the seconds it took."""
    t0 = time.monotonic()
    wait_for(lambda: predicate(rows(driver)), timeout, interval=0.02, what=what)
    return time.monotonic() - t0


def test_live_table_details_description_and_network(daemon, realdds_server, free_domain, browser):
    from selenium.webdriver.common.by import By

    server = realdds_server(free_domain, [], name="web-test-server")
    d = daemon([free_domain])
    browser.get(d.url + "/")
    assert browser.title.startswith("RealSense cameras")
    wait_for(lambda: browser.find_element(By.ID, "link-text").text == "live", 10, what="the page's stream live")
    assert rows(browser) == {}
    assert browser.find_element(By.ID, "devices-empty").is_displayed()

    # A camera appears: the page shows it within a second of the daemon listing it.
    camera = device_info(1, name="Intel RealSense D455 web")
    server.command(cmd="add", info=camera, spec=SPEC)
    wait_for(lambda: len(d.devices()) == 1, 15, what="the daemon listing the camera")
    took = wait_rows(browser, lambda r: "Intel RealSense D455 web" in r, 5, "the camera on the page")
    assert took <= 1.0, f"the page showed the camera {took:.2f} s after the daemon listed it"
    print(f"page: camera shown {took * 1000:.0f} ms after the daemon listed it")
    row = rows(browser)["Intel RealSense D455 web"]
    assert camera["serial"] in row["text"] and f"domain {free_domain}" in row["text"] and "ok" in row["text"]

    # Its details, then its description (streams asked of the camera by the daemon).
    browser.find_element(By.CSS_SELECTOR, f'#devices tr[data-id="{row["id"]}"]').click()
    details = browser.find_element(By.ID, "details")
    assert details.is_displayed() and camera["topic-root"] in details.text
    browser.find_element(By.ID, "describe").click()
    def description():
        return browser.find_element(By.ID, "description").text
    described = wait_for(lambda: all(st["name"] in description() for st in SPEC["streams"]), 40, fail=False)
    assert described, "not the camera's streams on the page: " + description()
    assert "848×480 16UC1 @30" in description()  # a depth profile as the server declared it

    # A camera in recovery stands out.
    broken = device_info(2, name="Intel RealSense D455 recovery", recovery=True)
    server.command(cmd="add", info=broken)
    wait_rows(browser, lambda r: "Intel RealSense D455 recovery" in r, 15, "the recovery camera on the page")
    recovery = rows(browser)["Intel RealSense D455 recovery"]
    assert "recovery" in recovery["class"] and "recovery" in recovery["text"]

    # The network view: the realdds server, a Fast DDS participant with two cameras.
    browser.find_element(By.ID, "tab-participants").click()
    wait_for(lambda: "web-test-server" in rows(browser, "participants"), 10, what="the server in the network view")
    line = rows(browser, "participants")["web-test-server"]["text"]
    assert "fast-dds" in line and "alive" in line and "2" in line
    assert f"{free_domain} (running)" in browser.find_element(By.ID, "domains").text
    browser.find_element(By.ID, "tab-devices").click()
    browser.save_screenshot(os.path.join(ARTIFACTS, "web-page.png"))

    # 'stopping': gone from the page as from the daemon.
    server.command(cmd="disconnect", **{"topic-root": camera["topic-root"]})
    wait_for(lambda: dds_gone(d, camera), 10, what="the daemon dropping the camera")
    took = wait_rows(browser, lambda r: "Intel RealSense D455 web" not in r, 5, "the camera gone from the page")
    assert took <= 1.0, f"the page dropped the camera {took:.2f} s after the daemon did"
    print(f"page: camera gone {took * 1000:.0f} ms after the daemon dropped it")
    # ... and listed as left, with why.
    wait_for(lambda: "stopping" in browser.find_element(By.ID, "gone-list").text, 5, what="the camera listed as left")
    assert f"dds-{free_domain}-" + camera["topic-root"].replace("/", ".") in browser.find_element(By.ID, "gone-list").text
    assert "1 camera" in browser.find_element(By.ID, "health").text or "(1)" in browser.find_element(By.ID, "count").text


def test_another_hosts_camera_shows_its_host(daemon, free_domain, browser):
    # A USB camera another host's daemon shares (issue 25): the page says whose it is.
    import subprocess
    import sys

    from conftest import JsonLinesProcess
    from selenium.webdriver.common.by import By

    d = daemon([free_domain])
    tools = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tools")
    peer = JsonLinesProcess([sys.executable, os.path.join(tools, "share_peer.py"), "--domain", str(free_domain)],
                            stdin=subprocess.PIPE)
    try:
        assert peer.lines.get(timeout=40) == {"matched": True}
        peer.proc.stdin.write(json.dumps({"flood": 1, "host": "lab-pc-7"}) + "\n")
        peer.proc.stdin.flush()
        assert peer.lines.get(timeout=30) == {"ok": True}
        wait_for(lambda: [x["source"] for x in d.devices()] == ["remote-usb"], 15, what="the shared camera listed")
        browser.get(d.url + "/")
        wait_rows(browser, lambda r: "Intel RealSense D455" in r, 10, "the shared camera on the page")
        row = rows(browser)["Intel RealSense D455"]
        assert "host lab-pc-7 (192.0.2.9)" in row["text"] and "flood-0" in row["text"], row["text"]
        browser.find_element(By.CSS_SELECTOR, f'#devices tr[data-id="{row["id"]}"]').click()
        assert "shared by" in browser.find_element(By.ID, "details").text
    finally:
        peer.proc.stdin.close()
        peer.proc.wait(30)


def dds_gone(d, info):
    return all(x.get("topic-root") != info["topic-root"] for x in d.devices())


def test_phone_sized_and_dark(daemon, realdds_server, free_domain, browser):
    from selenium.webdriver.common.by import By

    server = realdds_server(free_domain, [device_info(3, name="Intel RealSense D435 phone")])
    d = daemon([free_domain])
    browser.execute_cdp_cmd("Emulation.setDeviceMetricsOverride",
                            {"width": 390, "height": 844, "deviceScaleFactor": 2, "mobile": True})
    browser.execute_cdp_cmd("Emulation.setEmulatedMedia",
                            {"features": [{"name": "prefers-color-scheme", "value": "dark"}]})
    browser.get(d.url + "/")
    wait_rows(browser, lambda r: "Intel RealSense D435 phone" in r, 15, "the camera on the phone-sized page")
    # Cards, not a table too wide for the screen; dark colours.
    assert not browser.find_element(By.CSS_SELECTOR, "#devices thead").is_displayed()
    width = browser.execute_script("return document.documentElement.scrollWidth")
    assert width <= 390, f"the page is {width} px wide on a 390 px screen"
    background = browser.execute_script("return getComputedStyle(document.body).backgroundColor")
    assert background == "rgb(17, 21, 28)", background
    browser.save_screenshot(os.path.join(ARTIFACTS, "web-page-phone-dark.png"))
    server.quit()


def test_spec_is_served_as_shipped(daemon, free_domain):
    d = daemon([free_domain])
    status, headers, body = d.request("/openapi.yaml", via="tcp")
    assert status == 200 and headers["content-type"] == "application/yaml"
    source = os.path.join(os.environ.get("RSD_SOURCE_DIR", ""), "proto", "openapi.yaml")
    with open(source, "rb") as f:
        assert body == f.read()
    status, headers, body = d.request("/", via="unix")
    assert status == 200 and headers["content-type"] == "text/html; charset=utf-8"
    assert "connect-src 'self'" in headers["content-security-policy"]
    assert b"<script" in body and b"src=\"http" not in body and b"href=\"http" not in body  # nothing from elsewhere
    status, _, body = d.request("/?page=2")
    assert status == 400 and json.loads(body)["status"] == 400


def test_options_hover_and_stale(daemon, realdds_server, free_domain, browser, tmp_path):
    """Option values and ranges as `rs-discover describe` shows them; a camera in
    recovery keeps its colour under the pointer; while the daemon is unreachable the
    table says its state is unknown, not ok, and comes back when the daemon does."""
    import subprocess
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    camera = device_info(4, name="Intel RealSense D455 options")
    broken = device_info(5, name="Intel RealSense D455 broken", recovery=True)
    server = realdds_server(free_domain, [], name="web-options-server")
    server.command(cmd="add", info=camera, spec=SPEC)
    server.command(cmd="add", info=broken)
    d = daemon([free_domain])
    wait_for(lambda: len(d.devices()) == 2, 20, what="both cameras")
    browser.get(d.url + "/")
    wait_rows(browser, lambda r: "Intel RealSense D455 broken" in r and "Intel RealSense D455 options" in r, 15,
              "both cameras on the page")

    # Hover: a plain row is tinted, the recovery one keeps its red.
    def background(name):
        return browser.execute_script(
            "return getComputedStyle([...document.querySelectorAll('#devices tbody tr')]"
            ".find((tr) => tr.cells[0].innerText === arguments[0])).backgroundColor", name)
    before = background("Intel RealSense D455 broken")
    row = browser.find_element(By.CSS_SELECTOR, f'#devices tr[data-id="{rows(browser)["Intel RealSense D455 broken"]["id"]}"]')
    ActionChains(browser).move_to_element(row).perform()
    assert browser.execute_script("return document.querySelector('#devices tbody tr:hover') !== null")
    assert background("Intel RealSense D455 broken") == before == "rgb(255, 227, 227)"

    # The options, valued as describe prints them.
    options_id = rows(browser)["Intel RealSense D455 options"]["id"]
    browser.find_element(By.CSS_SELECTOR, f'#devices tr[data-id="{options_id}"]').click()
    browser.find_element(By.ID, "describe").click()
    wait_for(lambda: browser.execute_script("return !!document.getElementById('options')"), 40,
             what="the options table")
    shown = {r["first"]: r["text"] for r in browser.execute_script("""
        return [...document.querySelectorAll('#options tbody tr')].map((tr) => ({
          first: tr.cells[0].innerText, text: [...tr.cells].map((c) => c.innerText).join('|')}));""")}
    cli = os.path.join(ARTIFACTS, "client", "rs-discover")
    described = subprocess.run([cli, "--endpoint", "unix:" + d.socket, "describe", options_id],
                               capture_output=True, text=True, timeout=60)
    assert described.returncode == 0, described.stderr
    expected = {"Laser Power": "150 (0..360, step 30, default 150)",
                "Exposure": "8500 (1..165000, step 1, default 8500)",
                "Backlight Compensation": "0 (0..1, step 1, default 0)"}
    for name, value in expected.items():
        assert value in shown[name], shown
        assert any(line.startswith(name) and value in line for line in described.stdout.splitlines()), described.stdout
    assert shown["Laser Power"].split("|")[1] == "device" and shown["Exposure"].split("|")[1] == "Depth"

    # The daemon goes away: the table is marked stale, no camera said to be ok.
    port = d.port
    d.stop()
    wait_for(lambda: "stale" in browser.find_element(By.ID, "devices").get_attribute("class"), 15,
             what="the table marked stale")
    assert browser.find_element(By.ID, "stale").is_displayed()
    assert "unreachable" in browser.find_element(By.ID, "stale").text
    states = [r["text"].split("\t")[-1] for r in rows(browser).values()]
    assert all("ok" not in s and "unknown" in s for s in states), states
    # It comes back on the same port: live again, the states as they are.
    d2 = daemon([free_domain], extra=["--http", f"127.0.0.1:{port}"])
    wait_for(lambda: len(d2.devices()) == 2, 20, what="both cameras in the restarted daemon")
    wait_for(lambda: "stale" not in browser.find_element(By.ID, "devices").get_attribute("class"), 20,
             what="the table live again")
    assert not browser.find_element(By.ID, "stale").is_displayed()
    assert "ok" in rows(browser)["Intel RealSense D455 options"]["text"]
    server.quit()


def test_selection_deep_link_and_times_on_a_phone(daemon, realdds_server, free_domain, browser):
    """A link to a camera (#id) opens its details; the selected row stands out and its
    details, below the list on a phone, are scrolled into view; times are shown in UTC,
    how long ago, and in the browser's time zone."""
    from datetime import datetime, timedelta
    from selenium.webdriver.common.by import By

    infos = [device_info(30 + i, name=f"Intel RealSense D435 n{i}") for i in range(6)]
    server = realdds_server(free_domain, infos)
    d = daemon([free_domain])
    wait_for(lambda: len(d.devices()) == 6, 20, what="six cameras")
    listed = sorted(d.devices(), key=lambda x: x["id"])
    browser.execute_cdp_cmd("Emulation.setDeviceMetricsOverride",
                            {"width": 390, "height": 844, "deviceScaleFactor": 2, "mobile": True})
    browser.execute_cdp_cmd("Emulation.setTimezoneOverride", {"timezoneId": "Asia/Kolkata"})  # UTC+05:30

    def in_view(element_id):
        return browser.execute_script("""const r = document.getElementById(arguments[0]).getBoundingClientRect();
            return r.height > 0 && r.top >= 0 && r.top < window.innerHeight;""", element_id)

    def selected_rows():
        return [r["id"] for r in rows(browser).values() if "selected" in r["class"].split()]

    # A deep link to the last camera: its details open, in view, its row selected.
    last = listed[-1]
    browser.get(d.url + "/#" + last["id"])
    wait_for(lambda: browser.find_element(By.ID, "details").is_displayed(), 15, what="the linked camera's details")
    assert last["id"] in browser.find_element(By.ID, "details").text
    assert selected_rows() == [last["id"]]
    assert browser.execute_script("return document.documentElement.scrollHeight") > 844  # the list is long
    wait_for(lambda: in_view("details"), 5, what="the details scrolled into view")

    # The times: UTC as the API has it, how long ago, and the local time (UTC+05:30).
    text = browser.find_element(By.ID, "details").text
    seen = datetime.strptime(last["first-seen"][:19], "%Y-%m-%dT%H:%M:%S")
    local = seen + timedelta(hours=5, minutes=30)
    assert seen.strftime("%Y-%m-%d %H:%M:%S UTC") in text, text
    assert " s ago" in text or " min ago" in text, text
    assert f"{local.hour % 12 or 12}:{local.minute:02d}:{local.second:02d}" in text, text

    # Picking the first row (a tap at the top of the list): selected, linked, details in view.
    # (A click event on the row: WebDriver's pointer lands off target under the phone's
    # emulated scale factor.)
    first = listed[0]
    browser.execute_script("window.scrollTo(0, 0)")
    browser.execute_script("arguments[0].click()",
                           browser.find_element(By.CSS_SELECTOR, f'#devices tr[data-id="{first["id"]}"]'))
    assert selected_rows() == [first["id"]]
    assert browser.execute_script("return location.hash") == "#" + first["id"]
    assert first["serial"] in browser.find_element(By.ID, "details-title").text
    wait_for(lambda: in_view("details"), 5, what="the details scrolled into view")
    shadow = browser.execute_script(
        "return getComputedStyle(document.querySelector('#devices tr.selected')).boxShadow")
    assert shadow != "none", shadow
    # The link, opened anew, shows the same camera.
    browser.get(d.url + "/#" + first["id"])
    wait_for(lambda: browser.find_element(By.ID, "details").is_displayed(), 15, what="the details from the link")
    assert first["serial"] in browser.find_element(By.ID, "details-title").text
    server.quit()


def test_a_cameras_details_show_who_uses_it(daemon, realdds_server, free_domain, browser):
    """The details of a network camera say whether it is in use and list its clients
    (GET /v1/devices/{id}/clients) with what they stream, and follow them as they come
    and go: a real pyrealdds program streaming Depth."""
    import sys

    from selenium.webdriver.common.by import By

    sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "interop"))
    from test_clients import Client, served_d555

    d, x, xid = served_d555(free_domain, daemon, realdds_server, "556222")
    browser.get(d.url + "/#" + xid)
    details = browser.find_element(By.ID, "details")
    wait_for(lambda: details.is_displayed() and "no client: free" in details.text, 10, what="the camera free",
             fail=False) or pytest.fail("not free on the page: " + details.text)

    viewer = Client(free_domain, x, "depth-viewer", streams=["Depth"])
    try:
        wait_for(lambda: "1 client, streaming Depth" in details.text, 10, what="in use on the page")

        def clients_table():
            return browser.execute_script("""
                const t = document.getElementById('clients-table');
                return t ? [...t.tBodies[0].rows].map((r) => [...r.cells].map((c) => c.innerText)) : null;""")
        wait_for(lambda: clients_table() and clients_table()[0][0] == "depth-viewer", 10, what="the client listed")
        [row] = clients_table()
        listed = d.get_json(f"/v1/devices/{xid}/clients")["clients"][0]
        assert row[1] == ", ".join(listed["addresses"]) and row[2] == "fast-dds" and row[4] == "Depth", row
        browser.save_screenshot(os.path.join(ARTIFACTS, "web-page-clients.png"))
    finally:
        viewer.quit()
    wait_for(lambda: "no client: free" in details.text, 10, what="free again on the page")
    assert clients_table() is None or clients_table() == []
