# A closed-loop simulator written apart from the project's (no code shared with
# datasets::simulate), for the measurement in 2026-11-29-proportional-controllers.md:
#   python3 2026-11-29-independent-simulator.py OUT_DIR SEED LOOPS
# writes OUT_DIR/loopNNN.csv (t, SP, PV, OP), OUT_DIR/mvNNN.npy (the true valve position) and
# OUT_DIR/labels.json; then `stiction detect FILE --json` on each file, scored against labels.json.
import numpy as np, sys, os, json
rng=np.random.default_rng(int(sys.argv[2]) if len(sys.argv)>2 else 7)
out=sys.argv[1]; os.makedirs(out,exist_ok=True)
labels=[]
for i in range(int(sys.argv[3]) if len(sys.argv)>3 else 60):
    sticky = i%2==0
    Ts=float(rng.choice([1.0,1.0,2.0,5.0,10.0]))
    tau=float(np.exp(rng.uniform(np.log(5),np.log(200))))
    theta=float(rng.uniform(0,0.5*tau))
    K=float(rng.uniform(0.5,2.0))
    second = rng.random()<0.3
    lam=max(theta,tau*rng.uniform(0.3,1.5))
    Kc=tau/(K*(lam+theta)); Ti=min(tau,4*(lam+theta))
    N=int(rng.integers(1000,4000))
    S=float(np.exp(rng.uniform(np.log(1),np.log(10)))) if sticky else 0.0
    J=float(rng.uniform(0,S)) if sticky else 0.0
    sig=float(rng.uniform(0.05,0.5))
    dt=0.1; steps=int(round(Ts/dt))
    warm=int(600/Ts)+200
    tot=N+warm
    sp=np.full(tot,50.0)
    for k in rng.integers(warm,tot,size=int(rng.integers(0,4))): sp[k:]+=rng.uniform(-5,5)
    dist=np.cumsum(rng.normal(0,0.02*np.sqrt(Ts),tot))  # load random walk (in valve %)
    if rng.random()<0.3: dist+=rng.uniform(1,4)*np.sin(2*np.pi*np.arange(tot)*Ts/rng.uniform(100,1000))
    y=50.0; y2=50.0; op=np.zeros(tot); pv=np.zeros(tot); mvv=np.zeros(tot)
    integ=50.0; buf=[50.0]*(int(theta/dt)+1)
    mvstate=dict(xss=50.0,stuck=True,prev=50.0,vprev=0.0,mv=50.0)
    e_prev=0
    for k in range(tot):
        meas=y+rng.normal(0,sig)
        pv[k]=meas
        e=sp[k]-meas
        integ+=Kc*Ts/Ti*e
        integ=min(max(integ,-50),150)
        u=min(max(integ+Kc*e,0),100)
        op[k]=u
        # the valve: stuck until OP leaves the band S around where it stuck, then slips to
        # OP - (S - J)/2 and follows OP; it sticks again where OP reverses or stops
        # (a two-parameter stick-slip valve after Choudhury, Thornhill and Shah, 2005)
        st=mvstate
        v=u-st['prev']
        if st['stuck']:
            if abs(u-st['xss'])>S:
                st['mv']=u-np.sign(u-st['xss'])*(S-J)/2; st['stuck']=False
        else:
            if v==0 or (np.sign(v)!=np.sign(st['vprev']) and st['vprev']!=0):
                st['stuck']=True; st['xss']=st['prev']
            else:
                st['mv']=u-np.sign(v)*(S-J)/2 if S>0 else u
        if S==0: st['mv']=u
        if v!=0: st['vprev']=v
        st['prev']=u
        mvv[k]=st['mv']
        for _ in range(steps):
            buf.append(st['mv']+dist[k]); xin=buf.pop(0)
            if second:
                y2+=dt/(0.3*tau)*(K*(xin-50)+50-y2); y+=dt/tau*(y2-y)
            else:
                y+=dt/tau*(K*(xin-50)+50-y)
    s=slice(warm,tot)
    np.save(f"{out}/mv{i:03d}.npy", mvv[s])
    name=f"{out}/loop{i:03d}.csv"
    with open(name,'w') as f:
        f.write("t,SP,PV,OP\n")
        for k,(a,b,c) in enumerate(zip(sp[s],pv[s],op[s])): f.write(f"{k*Ts:.1f},{a:.4f},{b:.4f},{c:.4f}\n")
    labels.append(dict(file=os.path.basename(name),sticky=sticky,S=S,J=J,Ts=Ts,tau=tau,theta=theta,N=N,second=second,sig=sig))
json.dump(labels,open(f"{out}/labels.json",'w'),indent=0)
