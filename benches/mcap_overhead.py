"""Recording overhead of `simulate --mcap` (issue 15): N interleaved pairs of
`truss-deploy simulate MODEL` and `... --mcap /tmp/wb.mcap`, wall time
(perf_counter) and CPU time (rusage) of each process; prints the ratios of the
minima and of the medians.

    python3 benches/mcap_overhead.py target/release/truss-deploy models/double_ring_synchronized.toml 20
"""
import subprocess, time, statistics as S, sys, os
B=sys.argv[1]; M=sys.argv[2]; n=int(sys.argv[3])
res={'plain':[], 'mcap':[]}
for i in range(n):
    for k,extra in (('plain',[]),('mcap',['--mcap','/tmp/wb.mcap'])):
        t=time.perf_counter()
        p=subprocess.Popen([B,'simulate',M]+extra,stdout=subprocess.DEVNULL)
        _,st,ru=os.wait4(p.pid,0)
        res[k].append((time.perf_counter()-t, ru.ru_utime+ru.ru_stime))
for j,name in ((0,'wall'),(1,'cpu')):
    p=[x[j] for x in res['plain']]; m=[x[j] for x in res['mcap']]
    print(f"{name}: plain min {min(p):.4f} med {S.median(p):.4f}; mcap min {min(m):.4f} med {S.median(m):.4f}; ratio min {min(m)/min(p):.3f} med {S.median(m)/S.median(p):.3f}")
