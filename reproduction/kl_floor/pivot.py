"""Pivot floor.csv: the implied c of every estimator at each sample size, one row an estimator."""
import csv, collections
rows=list(csv.DictReader(open('floor.csv')))
d=collections.OrderedDict()
for r in rows:
    d.setdefault(r['est'],{})[(int(r['N']),int(r['M']))]=r
keys=[(100,100),(1000,1000),(6400,6400),(64000,64000),(100,1000),(100,5000)]
print(f"{'estimator':40s} "+" ".join(f"{str(k):>13s}" for k in keys)+"   (c_pq nats; [occ bins])")
for e,v in d.items():
    print(f"{e:40s} "+" ".join(f"{float(v[k]['c_pq']):7.3f}[{float(v[k]['occ']):4.1f}]" if v[k]['occ']!='nan' else f"{float(v[k]['c_pq']):7.3f}      " for k in keys))
