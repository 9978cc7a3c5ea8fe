import csv,sys
def med(v): v=sorted(v); return v[len(v)//2] if v else -1
def p(v,q): v=sorted(v); return v[min(len(v)-1,int(q*len(v)))] if v else -1
pre_k=['free_motion_ms','traverse_ms','interpenetration_ms','refit_ms','fill_w_rigid_ms','fill_w_deform_ms']
for f in sys.argv[1:]:
  rows=[r for r in csv.DictReader(open(f)) if r['rendering']=='0' and 1000<=int(r['step'])%2900<1500]
  t=[float(r['traverse_ms']) for r in rows]
  pre=[sum(float(r[k]) for k in pre_k) for r in rows]
  st=[float(r['step_ms']) for r in rows]
  print('%-14s trav med %.4f p90 %.4f p99 %.4f max %.4f | pre med %.4f p99 %.4f max %.4f | step med %.4f p99 %.4f | builds %d'%(f[-14:],med(t),p(t,.9),p(t,.99),max(t),med(pre),p(pre,.99),max(pre),med(st),p(st,.99),sum(int(r['cache_builds']) for r in rows)))
