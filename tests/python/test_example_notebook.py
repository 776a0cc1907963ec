"""The example notebook (examples/notebooks/voxbrick.ipynb) executed headless by `jupyter nbconvert --execute` against
the real server, its address passed as the notebook reads it ($VOXBRICK_SERVER, $VOXBRICK_VIEWER); what it saves is
the server's frames. ctest runs this file alone (python.notebook)."""
from __future__ import annotations

import os
import subprocess
import sys

import nbformat
import numpy as np

import voxbrick
from conftest import SOURCE_DIR, TOKEN, largest_difference

NOTEBOOK = SOURCE_DIR / 'examples' / 'notebooks' / 'voxbrick.ipynb'


def test_the_example_notebook_runs_against_a_server(server, tmp_path):
    env = dict(os.environ, VOXBRICK_SERVER=server.address, VOXBRICK_VIEWER=f'{server.viewer}/?token={TOKEN}',
               VOXBRICK_OUTPUT=str(tmp_path), VOXBRICK_DATASET='mri.vbs')
    env.pop('PYTHONPATH', None)  # the notebook finds the package in the source tree itself
    result = subprocess.run([sys.executable, '-m', 'nbconvert', '--to', 'notebook', '--execute', str(NOTEBOOK),
                             '--output-dir', str(tmp_path), '--output', 'executed',
                             '--ExecutePreprocessor.timeout=120'],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    assert result.returncode == 0, result.stdout
    executed = nbformat.read(tmp_path / 'executed.ipynb', as_version=4)
    outputs = [o for cell in executed.cells if cell.cell_type == 'code' for o in cell.outputs]
    assert not [o for o in outputs if o.output_type == 'error' or o.get('name') == 'stderr'], outputs

    # The three named views, side by side: the server's frames of them.
    strip = voxbrick.read_png(str(tmp_path / 'mri-views.png'))
    assert strip.shape == (256, 768, 4)
    with voxbrick.connect(server.address) as client:
        views = [client.render('mri.vbs', camera=v, tf='mri', size=(256, 256), shading=True)
                 for v in ('anterior', 'left', 'superior')]
        assert largest_difference(strip, np.concatenate(views, axis=1)) <= 1  # PROTOCOL.md: within 1/255
        assert all(not np.array_equal(a, b) for a, b in [(views[0], views[1]), (views[1], views[2])])
        assert all(v[..., :3].max() > 100 for v in views)
        assert voxbrick.read_png(str(tmp_path / 'mri-orbit.png')).shape == (256, 512, 4)
        # The viewer's cell shows the view as set() left it, and the snapshot is that view's frame.
        snapshot = voxbrick.read_png(str(tmp_path / 'mri-snapshot.png'))
        expected = client.render('mri.vbs', camera=(45, 20), tf='mri', size=(384, 384), shading=True)
        assert largest_difference(snapshot, expected) <= 1
    html = [o.data['text/html'] for o in outputs if 'text/html' in o.get('data', {})]
    assert len(html) == 1 and f'{server.viewer}/?dataset=mri.vbs&amp;orbit=45,20&amp;tf=mri&amp;shading=1' in html[0]
    assert 'voxbrick-hello' in html[0]
