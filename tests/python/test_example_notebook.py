"""The example notebook (examples/notebooks/voxbrick.ipynb) executed headless by `jupyter nbconvert --execute` against
the real server, its address and token passed as the notebook reads them ($VOXBRICK_SERVER, $VOXBRICK_VIEWER,
$VOXBRICK_TOKEN); what it saves is the server's frames, and the volume it makes is a dataset of the server. ctest runs
this file alone (python.notebook)."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys

import nbformat
import numpy as np
import pytest

import voxbrick
from conftest import SOURCE_DIR, TOKEN, Server, largest_difference

NOTEBOOK = SOURCE_DIR / 'examples' / 'notebooks' / 'voxbrick.ipynb'


@pytest.fixture
def uploads_server(datasets, tmp_path):
    """A server over the MRI alone, taking uploads (`[upload] max_bytes`) from its single token (`--http-token`)."""
    folder = tmp_path / 'datasets'
    shutil.copytree(datasets / 'mri.vbs', folder / 'mri.vbs', copy_function=os.link)
    config = tmp_path / 'server.toml'
    config.write_text('[upload]\nmax_bytes = 16777216\n')
    s = Server(folder, tmp_path, extra=('--config', str(config)))
    yield s, folder
    s.stop()


def test_the_example_notebook_runs_against_a_server(uploads_server, tmp_path):
    server, folder = uploads_server
    output = tmp_path / 'output'
    output.mkdir()
    env = dict(os.environ, VOXBRICK_SERVER=server.address, VOXBRICK_VIEWER=server.viewer, VOXBRICK_TOKEN=TOKEN,
               VOXBRICK_OUTPUT=str(output), VOXBRICK_DATASET='mri.vbs')
    env.pop('PYTHONPATH', None)  # the notebook finds the package in the source tree itself
    result = subprocess.run([sys.executable, '-m', 'nbconvert', '--to', 'notebook', '--execute', str(NOTEBOOK),
                             '--output-dir', str(output), '--output', 'executed',
                             '--ExecutePreprocessor.timeout=120'],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    assert result.returncode == 0, result.stdout
    executed = nbformat.read(output / 'executed.ipynb', as_version=4)
    outputs = [o for cell in executed.cells if cell.cell_type == 'code' for o in cell.outputs]
    assert not [o for o in outputs if o.output_type == 'error' or o.get('name') == 'stderr'], outputs

    # The three named views, side by side: the server's frames of them.
    strip = voxbrick.read_png(str(output / 'mri-views.png'))
    assert strip.shape == (256, 768, 4)
    with voxbrick.connect(server.address, token=TOKEN) as client:
        views = [client.render('mri.vbs', camera=v, tf='mri', size=(256, 256), shading=True)
                 for v in ('anterior', 'left', 'superior')]
        assert largest_difference(strip, np.concatenate(views, axis=1)) <= 1  # PROTOCOL.md: within 1/255
        assert all(not np.array_equal(a, b) for a, b in [(views[0], views[1]), (views[1], views[2])])
        assert all(v[..., :3].max() > 100 for v in views)
        assert voxbrick.read_png(str(output / 'mri-orbit.png')).shape == (256, 512, 4)
        # The volume the notebook made and sent: a dataset of the server now, a store in its folder, and the
        # frames the notebook saved are the server's of it.
        assert client.datasets() == ['blobs', 'mri.vbs']
        assert (folder / 'blobs' / 'store.json').exists()
        info = client.info('blobs')
        assert info['dims'] == [64, 64, 64] and info['type'] == 'f32' and info['value_range'][1] > 0.9
        blobs = [client.render('blobs', camera=v, tf='hot', size=(256, 256)) for v in ('anterior', 'left', 'superior')]
        saved = voxbrick.read_png(str(output / 'blobs-views.png'))
        assert largest_difference(saved, np.concatenate(blobs, axis=1)) <= 1
        assert not np.array_equal(blobs[0], blobs[1]) and blobs[0][..., :3].max() > 100
        # The viewer's cell shows the view as set() left it, and the snapshot is that view's frame.
        snapshot = voxbrick.read_png(str(output / 'mri-snapshot.png'))
        expected = client.render('mri.vbs', camera=(45, 20), tf='mri', size=(384, 384), shading=True)
        assert largest_difference(snapshot, expected) <= 1
    html = [o.data['text/html'] for o in outputs if 'text/html' in o.get('data', {})]
    assert len(html) == 1 and f'{server.viewer}/?dataset=mri.vbs&amp;orbit=45,20&amp;tf=mri&amp;shading=1' in html[0]
    assert f'token={TOKEN}' in html[0] and 'voxbrick-hello' in html[0]
