"""voxbrick.view without a browser: the view as URL parameters the viewer reads, the scene it asks, reports from the
viewer, refusals, and snapshots equal to `voxbrick render`'s frame. (The viewer in Chromium reporting its view and
the snapshot equal to its canvas: tests/browser/notebook.test.mjs.)"""
from __future__ import annotations

import json
import shutil
import subprocess
import urllib.parse

import numpy as np
import pytest

import voxbrick
import voxbrick.notebook as nb
from conftest import SOURCE_DIR, TOKEN, fresh, render_cli


def query(view):
    return dict(urllib.parse.parse_qsl(urllib.parse.urlsplit(view.url).query))


def test_the_url_carries_the_view(server):
    v = voxbrick.view('mri.vbs', server=f'{server.viewer}/?token={TOKEN}', camera='left', tf='mri', size=(200, 160))
    assert v.url.startswith(f'{server.viewer}/?dataset=mri.vbs&view=left&tf=mri&size=200x160&token=')
    assert query(v) == {'dataset': 'mri.vbs', 'view': 'left', 'tf': 'mri', 'size': '200x160', 'token': TOKEN}
    assert v.state == {'dataset': 'mri.vbs', 'view': 'left', 'az': 90.0, 'el': 0.0, 'dist': None, 'pan': [0.0, 0.0],
                       'tf': 'mri', 'points': None, 'window': None, 'shading': False, 'quality': '',
                       'size': [200, 160]}
    assert v.scene() == {'camera': {'view': 'left'}, 'size': [200, 160], 'transfer_function': 'mri',
                         'shading': False}
    points = [[0, 0, 0, 0, 0], [0.5, 1, 0.5, 0, 0.25], [1, 1, 1, 1, 1]]
    v.set(camera=(45.5, -10, 2.5), tf=np.array(points), window=(10, 120), shading=True, quality='psnr:40')
    assert query(v) == {'dataset': 'mri.vbs', 'orbit': '45.5,-10,2.5', 'tf': 'custom',
                        'points': '0,0,0,0,0;0.5,1,0.5,0,0.25;1,1,1,1,1', 'window': '10,120', 'shading': '1',
                        'quality': 'psnr:40', 'size': '200x160', 'token': TOKEN}
    assert v.scene() == {'camera': {'orbit': [45.5, -10.0, 2.5]}, 'size': [200, 160],
                         'transfer_function': {'points': points}, 'shading': True, 'window': [10.0, 120.0],
                         'quality': 'psnr:40'}
    v.set(dataset='sparse')  # another dataset: its own camera and window, the same transfer function
    assert (v.state['dataset'], v.state['az'], v.state['window'], v.state['tf']) == ('sparse', 30, None, 'custom')
    v.set(window=(1, 2), camera=(10, 20))
    v.set(window='full')
    assert (v.state['az'], v.state['window']) == (10, None)
    # The cell: the IFrame at this URL (HTML-escaped), sized for the frame and the viewer's panel, and its script.
    html = v._repr_html_()
    assert f'<iframe src="{v.url.replace("&", "&amp;")}"' in html
    assert 'width="462" height="420"' in html
    assert f'var id = "{v.id}", origin = "{server.viewer}"' in html
    assert '<script>' in html and 'voxbrick-hello' in html


def test_reports_from_the_viewer_become_the_state(server):
    v = voxbrick.view('mri.vbs', server=server.viewer, token=TOKEN, camera='left', size=(64, 64))
    reported = {'dataset': 'mri.vbs', 'view': None, 'az': -100.5, 'el': 33, 'dist': 2.5, 'pan': [0.1, -0.2],
                'tf': 'custom', 'points': [[0, 0, 0, 0, 0], [1, 1, 0.5, 0, 0.5]], 'window': [5, 99], 'shading': True,
                'quality': ''}
    nb._report(v.id, json.dumps({'view': reported, 'size': [80, 60]}))
    assert v.state == dict(reported, az=-100.5, el=33.0, size=[80, 60])
    before = v.state
    for bad in ['not json', json.dumps([1]), json.dumps({'view': dict(reported, el=95)}),
                json.dumps({'view': dict(reported, points=[[2, 0, 0, 0, 0]])}),
                json.dumps({'view': dict(reported, window=[9, 1])})]:
        nb._report(v.id, bad)
        assert v.state == before, bad  # what does not read as a view is dropped whole
    nb._report('0' * 32, json.dumps({'view': reported}))  # a view no longer there: nothing happens
    # A named view reported with no distance is the named view.
    nb._report(v.id, json.dumps({'view': dict(reported, view='superior', az=180, el=90, dist=None), 'size': [80, 60]}))
    assert v.scene()['camera'] != {'view': 'superior'}  # still panned: eye, centre and up
    nb._report(v.id, json.dumps({'view': dict(reported, view='superior', az=180, el=90, dist=None, pan=[0, 0])}))
    assert v.scene()['camera'] == {'view': 'superior'}


def test_bad_arguments_are_refused_naming_them(server):
    for kwargs, words in [
        (dict(server='ftp://host:1'), "an http:// address"),
        (dict(server='host'), 'expected "http://HOST:PORT"'),
        (dict(camera='front'), "camera 'front': a named view is one of"),
        (dict(camera={'eye': [0, 0, 1]}), "the viewer's camera is a named view or an orbit"),
        (dict(camera=(0, 100)), 'elevation in'),
        (dict(camera=(0, 0, 99)), 'distance in'),
        (dict(tf=[[0, 0, 0, 0]]), 'a list of'),
        (dict(tf=[[0, 0, 0, 0, 2]]), r'every number in \[0, 1\]'),
        (dict(tf={'points': [[0, 0, 0, 0, 1]], 'reference_length': 2}), "the viewer's curve has points only"),
        (dict(window=(5, 5)), 'hi must be above lo'),
        (dict(quality='fast'), "quality 'fast'"),
        (dict(size=(4096, 10)), 'each 1 to 2048'),
    ]:
        args = dict(dataset='mri.vbs', server=server.viewer)
        args.update(kwargs)
        with pytest.raises(ValueError, match=words):
            voxbrick.view(args.pop('dataset'), **args)


def test_a_snapshot_is_the_frame_voxbrick_render_draws(server, datasets, tmp_path):
    name = fresh()
    v = voxbrick.view(name, server=server.viewer, token=TOKEN, camera=(200, 30), tf='mri', window=(10, 120),
                      shading=True, size=(120, 90))
    image = v.snapshot()
    expected = voxbrick.read_png(str(render_cli(datasets / name, v.scene(), tmp_path / 'cli.png')))
    assert np.array_equal(image, expected)
    assert image.shape == (90, 120, 4) and image[..., :3].max() > 100
    # Through TCP (address=) as well, and a panned view.
    v2 = voxbrick.view('mri.vbs', server=server.viewer, token=TOKEN, address=server.address, camera=(200, 30),
                       size=(64, 48))
    v2.set(pan=(0.2, 0.1))
    panned = v2.snapshot()
    assert panned.shape == (48, 64, 4)
    with voxbrick.connect(server.address) as client:
        centred = client.render('mri.vbs', camera=(200, 30), size=(64, 48))
    assert not np.array_equal(panned, centred)
    v.close()
    v2.close()
    # A wrong token is the server's refusal.
    with pytest.raises(voxbrick.ConnectionRefused, match='HTTP 403: forbidden: wrong access token'):
        voxbrick.view('mri.vbs', server=server.viewer, token='wrong').snapshot()


def test_a_panned_camera_is_the_viewers(server):
    # web/js/view.js's sceneCamera, run by Node on the same views and metadata, gives the same eye, centre and up.
    node = shutil.which('node')
    assert node, 'node is needed (scripts/setup.sh installs it)'
    with voxbrick.connect(server.address) as client:
        metas = [client.info('mri.vbs'), client.info('sparse')]
    cases = []
    for meta in metas:
        for az, el, dist, pan in [(30, 20, None, [0.1, 0.2]), (-120, -40, 2.5, [-0.3, 0]), (90, 90, 1, [0, 0.5])]:
            state = {'view': None, 'az': az, 'el': el, 'dist': dist, 'pan': pan}
            cases.append((state, meta, [160, 90]))
    script = f"""
import * as V from {json.dumps((SOURCE_DIR / 'web' / 'js' / 'view.js').as_uri())};
const cases = JSON.parse(process.argv[1]);
console.log(JSON.stringify(cases.map(([view, meta, size]) => V.sceneCamera(view, meta, size[0] / size[1]))));
"""
    out = subprocess.run([node, '--input-type=module', '-e', script, json.dumps(cases)], stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True)
    assert out.returncode == 0, out.stdout
    for (state, meta, size), camera in zip(cases, json.loads(out.stdout)):
        ours = nb._panned_camera(state, meta, size)
        for key in ('eye', 'center', 'up'):
            assert ours[key] == pytest.approx(camera[key], abs=2e-6), (state, key)
