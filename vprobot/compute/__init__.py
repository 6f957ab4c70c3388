"""Computing resources: the numeric libraries' kernels pinned (`kernels`), worker
pools and child processes that end with their parent (`processes`), Ray
(`cluster`) and freed native memory handed back (`native_memory`).
"""
