#!/usr/bin/env python3
"""Thermal fit of the plant (docs/PLANT-API.md): a pure-Python replica of the Full network
(host-sim/src/plant/thermal.rs, backward Euler at 0.02 s) and a Gauss-Newton fit of heater power,
wall areal capacity, fan duct h and heater->wall h to: heater 298->323 K in 10 s, forming
(SMP outer 358->323 K, fan full, soaked wall) in 50 s, reheating (heater surface ->358 K) in 25 s."""
import math
PI=math.pi
Ain=PI*35*200e-6; Aout=PI*40*200e-6; Amid=0.5*(Ain+Aout)
Vd=PI/4*35*35*200e-9; Cair=Vd*1.19*1005
share=4/5.8
def net(p,fan):
    P,Cw,hf,hhw,hw,hout,Ch=p
    hd=4.0+(hf-4.0)*fan**0.8
    flow=(4e-5+6.6e-3*fan)*1.19*1005
    C=[Ch*Ain,Cw*Ain*share,Cw*Ain*(1-share),Cair]
    G=[[0]*4 for _ in range(4)]
    def l(i,j,g): G[i][j]+=g; G[j][i]+=g
    l(0,1,hhw*Ain); l(1,2,hw*Amid); l(0,3,hd*Ain)
    ga=[0,0,hout*Aout,flow]
    return C,G,ga
def solve(M,b):
    n=len(b); M=[r[:] for r in M]; b=b[:]
    for k in range(n):
        for i in range(k+1,n):
            f=M[i][k]/M[k][k]
            for j in range(k,n): M[i][j]-=f*M[k][j]
            b[i]-=f*b[k]
    x=[0]*n
    for k in reversed(range(n)):
        s=b[k]-sum(M[k][j]*x[j] for j in range(k+1,n)); x[k]=s/M[k][k]
    return x
def run(p,T,heat,fan,cond,limit=300,dt=0.02):
    C,G,ga=net(p,fan); n=4; Ta=298.15
    M=[[0]*n for _ in range(n)]
    for i in range(n):
        M[i][i]=C[i]/dt+ga[i]+sum(G[i])
        for j in range(n):
            if j!=i: M[i][j]=-G[i][j]
    t=0
    while t<limit:
        b=[C[i]/dt*T[i]+ga[i]*Ta+(p[0]*heat if i==0 else 0) for i in range(n)]
        Tn=solve(M,b); t+=dt
        if cond(Tn):
            return t,Tn
        T=Tn
    return None,T
def figs(p):
    t1,_=run(p,[298.15]*4,1,0,lambda T:T[0]>=323)
    t2,T=run(p,[358.0]*4,0,1,lambda T:T[2]<=323)
    t3,_=run(p,T,1,0,lambda T:T[0]>=358)
    return t1,t2,t3
base=[51.35,1687,30.7,119,54.6,13.4,280]
if False:
    print(figs(base))
idx=[0,1,2,3]  # P, Cw, hf, hhw
tgt=[10.0,50.0,25.0]
p=base[:]
def res(p):
    f=figs(p); return [f[i]-tgt[i] for i in range(3)]
for it in range(8):
    r=res(p); print(it,[round(x,3) for x in r],[round(p[i],3) for i in idx])
    if max(abs(x) for x in r)<0.05: break
    J=[]
    for i in idx:
        q=p[:]; q[i]*=1.03; rq=res(q); J.append([(rq[k]-r[k])/math.log(1.03) for k in range(3)])
    # least-norm solve J^T d = -r (3 eq, 4 unknowns): d = Jt (J Jt)^-1 (-r)  with J as list of columns
    A=[[sum(J[c][a]*J[c][b] for c in range(len(idx))) for b in range(3)] for a in range(3)]
    y=solve(A,[-x for x in r])
    d=[sum(J[c][a]*y[a] for a in range(3)) for c in range(len(idx))]
    for c,i in enumerate(idx): p[i]*=math.exp(max(-0.3,min(0.3,d[c])))
print(p, figs(p), "R=",18*18/p[0])
