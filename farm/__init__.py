"""Rendering on a Dask cluster: the sample windows of a frame traced by worker processes, on
this machine (`--workers N`) or others (`--cluster ADDRESS`), and merged in window order into
exactly the image one machine makes.

keys.py names a render's content (scene and settings) and its tasks; worker.py is what runs in
a worker process (a Renderer kept per render, one window per task); cluster.py connects to a
scheduler or starts a local one and checks its workers; render.py submits a frame's windows
and adds their sums in window order as they arrive; remote.py runs adaptive sampling's and
batches' schedulers here and their passes on the workers. Dask is an optional extra
(`pip install 'snell[distributed]'`): nothing here is imported unless a command asks for it.
"""
