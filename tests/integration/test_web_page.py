"""The daemon's page (GET /) in a real headless Chromium (Debian's, driven by
selenium): a realdds camera appears on it within a second of the daemon listing it
and goes on 'stopping'; its details and description open; a camera in recovery is
highlighted; the network view lists the realdds server. The spec is served at
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
    assert "1 camera" in browser.find_element(By.ID, "health").text or "(1)" in browser.find_element(By.ID, "count").text


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
