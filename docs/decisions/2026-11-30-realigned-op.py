"""Every second sample of a record, with OP realigned to the samples the part drops.

On the self-regulating loops of `cargo xtask detect-calibrate --no-plant --dump DUMP_DIR`:
`stiction detect --integrating no` on the whole record, on every second row, and on every
second row of PV and SP with OP taken from the row after each (the OP sample that set the
valve PV at the next kept row follows, for a process that answers within a sample). Prints
the AUC of each and the verdicts, for the loops with a dead time under a sample and the
others. Needs numpy, pandas, scikit-learn and a release build.
Usage: python3 2026-11-30-realigned-op.py DUMP_DIR [STICTION_BIN]
"""
import json, os, subprocess, sys
import numpy as np, pandas as pd
DUMP = sys.argv[1]
B = sys.argv[2] if len(sys.argv) > 2 else os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'target', 'release', 'stiction')
TMP = os.path.join(DUMP, 'realigned.csv')
idx = pd.read_csv(os.path.join(DUMP, 'index.csv'))
s=idx[(idx.judgeable==True)&(idx.integrating==False)]
def det(df):
    df.to_csv(TMP,index=False)
    j=json.loads(subprocess.run([B,'detect',TMP,'--json','--integrating','no'],capture_output=True,text=True).stdout)
    return j['score'], j['verdict']
rows=[]
for r in s.itertuples():
    df=pd.read_csv(os.path.join(DUMP, r.file))
    d0 = 'delay=0' in r.what
    n=len(df)//2*2
    ev=df.iloc[0:n:2].reset_index(drop=True)
    sh=ev.copy(); sh['OP']=df['OP'].values[1:n:2]
    a=det(df); b=det(ev); c=det(sh)
    rows.append((r.sticky,d0,a[0],b[0],c[0],a[1],b[1],c[1]))
t=pd.DataFrame(rows,columns=['sticky','d0','whole','even','shifted','vw','ve','vs'])
from sklearn.metrics import roc_auc_score
for name,m in [('all',t.d0|~t.d0),('delay 0',t.d0),('delay>0',~t.d0)]:
    u=t[m]
    print(name,len(u),'AUC whole %.3f even %.3f shifted %.3f'%(roc_auc_score(u.sticky,u.whole),roc_auc_score(u.sticky,u.even),roc_auc_score(u.sticky,u.shifted)))
    for v in ['vw','ve','vs']:
        print('   ',v,pd.crosstab(u.sticky,u[v]).to_dict())
