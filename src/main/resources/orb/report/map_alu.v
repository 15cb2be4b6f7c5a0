// orb.Report: an $alu (add, subtract, compare) becomes one carry-chain logic element per bit, as on Cyclone II.
(* techmap_celltype = "$alu" *)
module _orb_alu (A, B, CI, BI, X, Y, CO);
  parameter A_SIGNED = 0; parameter B_SIGNED = 0;
  parameter A_WIDTH = 1; parameter B_WIDTH = 1; parameter Y_WIDTH = 1;
  input [A_WIDTH-1:0] A; input [B_WIDTH-1:0] B; input CI, BI;
  output [Y_WIDTH-1:0] X, Y, CO;
  wire [Y_WIDTH-1:0] AA, BB;
  // (a negation -x is 0 - x with an empty A)
  generate
    if (A_WIDTH == 0) begin: a_none
      assign AA = 0;
    end else begin: a_ext
      \$pos #(.A_SIGNED(A_SIGNED), .A_WIDTH(A_WIDTH), .Y_WIDTH(Y_WIDTH)) ea (.A(A), .Y(AA));
    end
    if (B_WIDTH == 0) begin: b_none
      assign BB = 0;
    end else begin: b_ext
      \$pos #(.A_SIGNED(B_SIGNED), .A_WIDTH(B_WIDTH), .Y_WIDTH(Y_WIDTH)) eb (.A(B), .Y(BB));
    end
  endgenerate
  wire [Y_WIDTH:0] C;
  assign C[0] = CI;
  // One logic element per bit in arithmetic mode (a Cyclone II carry chain).
  genvar i;
  generate for (i = 0; i < Y_WIDTH; i = i + 1) begin: le
    ORB_CARRY c (.a(AA[i]), .b(BB[i]), .bi(BI), .ci(C[i]), .s(Y[i]), .co(C[i+1]));
  end endgenerate
  assign CO = C[Y_WIDTH:1];
  assign X = AA ^ (BB ^ {Y_WIDTH{BI}});
endmodule
