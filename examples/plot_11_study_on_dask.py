"""
A sweep study on a Dask cluster, read back as a labelled array
==============================================================

A physical strip (20 × 5 × 0.5 mm, χ̄ = 0.5) in a field across it, swept over the field magnitude
and the tip load, computed on a Dask cluster (here a local one with two workers; give
``--scheduler tcp://host:8786`` to ``actuator-design study`` for a real one). The study folder
holds ``results.csv`` and ``results.nc``: a netCDF dataset with one dimension per swept key (with
its unit), one variable per output and the per-point status, opened here with xarray and sliced.
"""
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import xarray as xr
from distributed import LocalCluster

import actuator_design as ad

study = {
    "name": "field and load sweep on Dask",
    "scene": {"type": "physical",
              "rod": {"length": "20 mm", "width": "5 mm", "thickness": "0.5 mm",
                      "youngs_modulus": "1 MPa"},
              "magnetics": {"chi_bar": 0.5},
              "field": {"type": "uniform", "magnitude": "10 kA/m", "angle": "90 deg"},
              "loads": {"tip_force": {"x": "0 N", "y": "0 mN"}},
              "fibres": "0 deg"},
    "solver": {"elements": 4, "degree": 10},
    "study": {"type": "sweep", "grid": "cartesian",
              "sweep": {"field.magnitude": {"from": "0 kA/m", "to": "30 kA/m", "n": 13},
                        "loads.tip_force.y": ["-0.02 mN", "0 mN", "0.02 mN"]},
              "analyses": ["solve"],
              "outputs": ["solve.success", "solve.stable", "solve.tip.*", "solve.physical.tip_*"]},
}
out = Path(tempfile.mkdtemp(prefix="study_dask_")) / "study"
with LocalCluster(processes=False, n_workers=2, threads_per_worker=1, dashboard_address=None) as cluster:
    report = ad.run_study(study, out, scheduler=cluster.scheduler_address, progress=False)
print(report.status, report.counts, "backend:", report.backend)

# %%
# The dataset: dimensions are the swept keys, with their units.
ds = xr.open_dataset(out / "results.nc")
print(ds)

# %%
# A slice: the tip's vertical position against the field, one line per tip load.
fig, ax = plt.subplots(figsize=(6.4, 4.4))
field = ds["field.magnitude"]
for load in ds["loads.tip_force.y"].values:
    sl = ds.sel({"loads.tip_force.y": load})
    ax.plot(field, sl["solve.tip.y"], marker="o", ms=3,
            label=f"tip load {load:g} {ds['loads.tip_force.y'].attrs.get('units', '')}")
ax.set_xlabel(f"field magnitude / {field.attrs.get('units', '')}")
ax.set_ylabel("tip y / rod lengths")
ax.legend(fontsize=8)
ax.grid(alpha=0.3)
ds.close()
