"""Batch runs: sweep files (``sweep``), scenarios on a process pool or a Dask cluster
(``pool``), the batch output directory (``store``) and plots of a batch (``report``)."""
